#include "server/geometry/pinch_closing.h"

#include <algorithm>
#include <cmath>

#include <gtest/gtest.h>

#include "server/geometry/mesh_build.h"
#include "server/geometry/metrics.h"
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
  Mesh mesh = build_mesh(testing::comb_cut_cylinder()).mesh;
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

}  // namespace
}  // namespace touchmend::geometry
