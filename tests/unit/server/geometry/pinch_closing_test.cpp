#include "server/geometry/pinch_closing.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include <gtest/gtest.h>

#include "server/geometry/mesh_build.h"
#include "server/geometry/metrics.h"
#include "server/geometry/patch_quality.h"
#include "tests/support/mesh_factory.h"

namespace touchmend::geometry {
namespace {

struct Pinched {
  Mesh mesh;
  Hole hole;
};

//! The grid with a round cut that leaves an island touching the rim at one vertex.
Pinched pinched_grid() {
  Pinched out{
      build_mesh(testing::cut_leaving_an_island(testing::grid(12, 12), {6, 6, 0}, 3.2)).mesh, {}};
  for (const Hole& h : find_holes(out.mesh).holes)
    if (!h.pinched_at.empty()) out.hole = h;
  return out;
}

// One triangle across a corner of the pinch: the loop passes the vertex once, is one vertex
// shorter, and is the loop the hole search now finds; the vertex is manifold again.
TEST(PinchClosing, OneTriangleMakesTheLoopADiskOneVertexShorter) {
  Pinched p = pinched_grid();
  ASSERT_EQ(p.hole.pinched_at.size(), 1u);
  const VertexHandle v = p.hole.pinched_at[0];
  ASSERT_EQ(std::count(p.hole.loop.begin(), p.hole.loop.end(), v), 2);
  EXPECT_EQ(validate_mesh(p.mesh).non_manifold_vertices, 1u);
  const SearchReach reach = make_search_reach(p.mesh);
  const PinchClosure closure = close_pinches(p.mesh, p.hole, reach);
  ASSERT_TRUE(closure.failure.empty()) << closure.failure;
  ASSERT_EQ(closure.faces.size(), 1u);
  EXPECT_EQ(closure.corners[0][1], v);
  EXPECT_EQ(closure.hole.loop.size(), p.hole.loop.size() - 1);
  EXPECT_EQ(std::count(closure.hole.loop.begin(), closure.hole.loop.end(), v), 1);
  EXPECT_EQ(closure.hole.id, p.hole.id);
  EXPECT_EQ(validate_mesh(p.mesh).non_manifold_vertices, 0u);
  // The hole search agrees: the same loop, no pinch.
  bool found = false;
  for (const Hole& h : find_holes(p.mesh).holes) {
    if (h.loop.size() != closure.hole.loop.size()) continue;
    EXPECT_TRUE(h.pinched_at.empty());
    EXPECT_TRUE(std::is_permutation(h.loop.begin(), h.loop.end(), closure.hole.loop.begin()));
    found = true;
  }
  EXPECT_TRUE(found);
}

// A loop through a vertex twice whose both corners' closing edges already exist in the mesh
// (here added as faces of their own beside the corners) cannot be closed: the reason says so,
// and what close_pinches added is listed for the caller to take out.
TEST(PinchClosing, CornersWhoseClosingEdgesExistAreRefused) {
  Pinched p = pinched_grid();
  ASSERT_EQ(p.hole.pinched_at.size(), 1u);
  const VertexHandle v = p.hole.pinched_at[0];
  const std::size_t n = p.hole.loop.size();
  // Every corner's p-a edge, made to exist by a face (p, a, w) on a new far vertex w.
  for (std::size_t i = 0; i < n; ++i) {
    if (p.hole.loop[i] != v) continue;
    const VertexHandle before = p.hole.loop[(i + n - 1) % n], after = p.hole.loop[(i + 1) % n];
    const VertexHandle w = p.mesh.add_vertex(Vec3(6, 6, 10 + static_cast<double>(i)));
    ASSERT_TRUE(p.mesh.add_face(before, w, after).is_valid() ||
                p.mesh.add_face(after, w, before).is_valid());
  }
  const SearchReach reach = make_search_reach(p.mesh);
  const PinchClosure closure = close_pinches(p.mesh, p.hole, reach);
  EXPECT_NE(closure.failure.find("no triangle closes its corners"), std::string::npos)
      << closure.failure;
  EXPECT_TRUE(closure.faces.empty());
}

// Each pinch of the comb is closed with the wall triangle between two teeth (its normal across
// the axis), not with a chord across the ring under them (its normal along the axis), though
// the chords have the larger smallest angles.
TEST(PinchClosing, ACombOfTeethIsClosedAlongTheWallNotAcrossTheRing) {
  Mesh mesh = build_mesh(testing::comb_cut_cylinder(testing::CombTeeth::Lone)).mesh;
  Hole hole;
  for (const Hole& h : find_holes(mesh).holes)
    if (h.pinched_at.size() > hole.pinched_at.size()) hole = h;
  ASSERT_GE(hole.pinched_at.size(), 4u);
  const SearchReach reach = make_search_reach(mesh);
  const PinchClosure closure = close_pinches(mesh, hole, reach);
  ASSERT_TRUE(closure.failure.empty()) << closure.failure;
  ASSERT_EQ(closure.faces.size(), hole.pinched_at.size());
  for (const FaceHandle f : closure.faces) {
    const Vec3 n = mesh.calc_face_normal(f);
    EXPECT_LT(std::abs(n[2]), 0.05) << "face " << f.idx() << " normal " << n;
  }
  EXPECT_EQ(validate_mesh(mesh).non_manifold_vertices, 0u);
}

//! The cut of an attached comb (testing::comb_cut_cylinder): the hole that is not one of the
//! cylinder's two open ends (48 edges each).
Hole attached_comb_hole(const Mesh& mesh) {
  for (const Hole& h : find_holes(mesh).holes)
    if (h.loop.size() != 48) return h;
  return {};
}

// The attached comb's gaps are narrow notches of its loop: each is closed with its ear, which
// is the triangle the cut took (on the wall: its normal across the axis; its corner the gap's
// 1.9°), and the loop left is the hole's, one vertex shorter per ear.
TEST(CloseNotches, ACombsGapsAreClosedWithTheTrianglesTheCutTook) {
  Mesh mesh = build_mesh(testing::comb_cut_cylinder(testing::CombTeeth::Attached)).mesh;
  const Hole hole = attached_comb_hole(mesh);
  ASSERT_GT(hole.loop.size(), 20u);
  const SearchReach reach = make_search_reach(mesh);
  const PinchClosure closure = close_notches(mesh, hole, reach);
  ASSERT_TRUE(closure.failure.empty()) << closure.failure;
  EXPECT_GE(closure.faces.size(), 6u);  // 7 teeth in the sector
  EXPECT_TRUE(closure.corners.empty());
  for (const FaceHandle f : closure.faces) {
    EXPECT_LT(std::abs(mesh.calc_face_normal(f)[2]), 0.05) << "face " << f.idx();
    EXPECT_NEAR(min_angle_deg(mesh, std::vector<FaceHandle>{f}), 1.87, 0.05);
  }
  EXPECT_EQ(closure.hole.loop.size(), hole.loop.size() - closure.faces.size());
  EXPECT_EQ(closure.hole.id, hole.id);
  EXPECT_EQ(validate_mesh(mesh).non_manifold_edges, 0u);
  bool found = false;
  for (const Hole& h : find_holes(mesh).holes)
    found = found || std::is_permutation(h.loop.begin(), h.loop.end(), closure.hole.loop.begin(),
                                         closure.hole.loop.end());
  EXPECT_TRUE(found);
}

// The tip of a spike of the surface into the hole is a narrow corner too, but its ear would lie
// on the spike's back: it is left to the fill.
TEST(CloseNotches, ASpikesTipIsNotANotch) {
  Mesh mesh = build_mesh(testing::grid_with_round_hole()).mesh;
  Hole hole;
  for (const Hole& h : find_holes(mesh).holes)
    if (h.loop.size() < 40) hole = h;  // the round hole, not the grid's border
  ASSERT_GT(hole.loop.size(), 8u);
  // Two triangles on the rim's consecutive u -> m -> w, meeting at a tip t across the hole.
  const VertexHandle u = hole.loop[0], m = hole.loop[1], w = hole.loop[2];
  const Vec3 inwards = (Vec3(8, 8, 0) - mesh.point(m)).normalize();
  const VertexHandle t = mesh.add_vertex(mesh.point(m) + 7.5 * inwards);
  ASSERT_TRUE(mesh.add_face(u, m, t).is_valid());
  ASSERT_TRUE(mesh.add_face(m, w, t).is_valid());
  const double tip_deg = std::acos(OpenMesh::dot((mesh.point(u) - mesh.point(t)).normalize(),
                                                 (mesh.point(w) - mesh.point(t)).normalize())) *
                         180 / std::numbers::pi;
  ASSERT_LT(tip_deg, 15.0);
  Hole spiked;
  for (const Hole& h : find_holes(mesh).holes)
    if (std::find(h.loop.begin(), h.loop.end(), t) != h.loop.end()) spiked = h;
  ASSERT_FALSE(spiked.loop.empty());
  const SearchReach reach = make_search_reach(mesh);
  const PinchClosure closure = close_notches(mesh, spiked, reach);
  EXPECT_TRUE(closure.faces.empty());
  EXPECT_EQ(closure.hole.loop, spiked.loop);
}

//! The ears close_notches makes on the slot of testing::grid_with_a_slot_along_a_fold.
std::size_t ears_on_a_slot_along_a_fold(double fold_deg) {
  Mesh mesh = build_mesh(testing::grid_with_a_slot_along_a_fold(fold_deg)).mesh;
  Hole slot;
  for (const Hole& h : find_holes(mesh).holes)
    if (h.loop.size() < 20) slot = h;  // not the grid's border
  EXPECT_GE(slot.loop.size(), 8u);
  const SearchReach reach = make_search_reach(mesh);
  const PinchClosure closure = close_notches(mesh, slot, reach);
  EXPECT_TRUE(closure.failure.empty()) << closure.failure;
  return closure.faces.size();
}

// A narrow notch whose two sides lie on the two faces of a crease: its ear would cut the crease
// off as a chamfer (it folds by about 45° against either face), so it is left to the fill,
// whose crease plan can keep the edge. The same slot on a flat grid is closed with its ear.
TEST(CloseNotches, AnEarAcrossACreaseIsNotClosed) {
  EXPECT_EQ(ears_on_a_slot_along_a_fold(90), 0u);   // a valley
  EXPECT_EQ(ears_on_a_slot_along_a_fold(-90), 0u);  // a ridge
  EXPECT_EQ(ears_on_a_slot_along_a_fold(0), 1u);
}

}  // namespace
}  // namespace touchmend::geometry
