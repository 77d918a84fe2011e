#include "server/geometry/ring_joining.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "server/geometry/hole_filling.h"
#include "server/geometry/mesh_build.h"
#include "server/geometry/mesh_intersections.h"
#include "server/geometry/metrics.h"
#include "tests/support/invariants.h"
#include "tests/support/mesh_factory.h"

namespace touchmend::geometry {
namespace {

//! A 16 x 16 grid with the ring of faces whose centroids lie 2 to 4 from its centre cut away:
//! the island inside stays. Three loops: the grid's border, the ring's outer border and the
//! island's border.
MeshSoup grid_with_a_ring_cut() {
  return testing::remove_faces(testing::grid(16, 16), [](const Vec3& c) {
    const double r = std::hypot(c[0] - 8, c[1] - 8);
    return r > 2 && r < 4;
  });
}

double area_of(const Mesh& mesh, const std::vector<FaceHandle>& faces) {
  double area = 0;
  for (const TrianglePoints& t : face_triangles(mesh, faces))
    area += 0.5 * OpenMesh::cross(t[1] - t[0], t[2] - t[0]).norm();
  return area;
}

// The ring's two borders are paired, the outer one first; the grid's border, around both and
// on their plane, is no border of the ring (its region lies outside it).
TEST(RingBorders, TheBordersOfACutRingArePairedAndTheSheetsBorderIsNot) {
  const Mesh mesh = build_mesh(grid_with_a_ring_cut()).mesh;
  const std::vector<Hole> holes = find_holes(mesh).holes;
  ASSERT_EQ(holes.size(), 3u);
  std::vector<const Hole*> all;
  for (const Hole& h : holes) all.push_back(&h);
  const auto pairs = find_ring_borders(mesh, all);
  ASSERT_EQ(pairs.size(), 1u);
  const Hole& outer = *all[pairs[0].first];
  const Hole& inner = *all[pairs[0].second];
  EXPECT_GT(outer.area, inner.area);
  EXPECT_LT(outer.area, 60.0);  // the ring's outer border (π 4² ≈ 50), not the grid's (256)
  EXPECT_FALSE(borders_one_ring(mesh, inner, outer));
}

// A loop of the other way round beside a hole, not inside it (an island cut free next to a
// round hole), or one loop inside another on a parallel plane far off it, are not the borders
// of one ring.
TEST(RingBorders, LoopsBesideOrOffThePlaneAreNotARing) {
  const Mesh beside = build_mesh(testing::remove_faces(testing::grid(16, 16), [](const Vec3& c) {
                        const double ring = std::hypot(c[0] - 11, c[1] - 8);
                        return std::hypot(c[0] - 3.5, c[1] - 8) < 2 || (ring > 1.5 && ring < 3.5);
                      })).mesh;
  std::vector<Hole> holes = find_holes(beside).holes;
  ASSERT_EQ(holes.size(), 4u);  // the sheet's border, the round hole, the ring's two borders
  std::vector<const Hole*> all;
  for (const Hole& h : holes) all.push_back(&h);
  const auto pairs = find_ring_borders(beside, all);
  ASSERT_EQ(pairs.size(), 1u);  // the ring's; the island is outside the round hole's outline
  const Hole& ring_outer = *all[pairs[0].first];
  const Hole& island = *all[pairs[0].second];
  EXPECT_NEAR(ring_outer.centroid[0], 11.0, 0.5);
  EXPECT_NEAR(island.centroid[0], 11.0, 0.5);
  // The round hole is larger than the island, on its plane and the other way round: only its
  // outline rules the island out.
  for (const Hole* h : all) {
    if (h->centroid[0] < 6) {
      EXPECT_FALSE(borders_one_ring(beside, *h, island));
    }
  }

  // The island lifted by 12 above the sheet: inside the outline, but over 3 radii off its
  // plane (a second level is taken up to 2 radii off).
  MeshSoup lifted = grid_with_a_ring_cut();
  for (Vec3& p : lifted.points)
    if (std::hypot(p[0] - 8, p[1] - 8) < 2.01) p[2] += 12;
  const Mesh stepped = build_mesh(lifted).mesh;
  holes = find_holes(stepped).holes;
  all.clear();
  for (const Hole& h : holes) all.push_back(&h);
  EXPECT_TRUE(find_ring_borders(stepped, all).empty());
}

// Filling every hole of the cut sheet closes the ring between its borders: one patch in the
// sheet's plane with the ring's area (not a disk over the island, nor a cap on it), the
// island untouched, the fill invariants kept. The inner border's report says which patch
// closed it.
TEST(RingBorders, FillingTheSheetClosesTheRingBetweenItsBorders) {
  Mesh mesh = build_mesh(grid_with_a_ring_cut()).mesh;
  const std::vector<Hole> holes = find_holes(mesh).holes;
  const testing::Snapshot before = testing::take_snapshot(mesh);
  std::vector<std::uint32_t> ring_ids;
  for (const Hole& h : holes)
    if (h.area < 60) ring_ids.push_back(h.id);
  ASSERT_EQ(ring_ids.size(), 2u);
  const FillReport report =
      fill_holes(mesh, FillSelection{.mode = FillSelection::Mode::Ids, .ids = ring_ids}, {});
  ASSERT_EQ(report.holes.size(), 2u);
  EXPECT_EQ(testing::check_fill_invariants(before, mesh, report.holes, holes), "");
  std::vector<FaceHandle> patch;
  std::size_t with_faces = 0;
  for (const HoleFillReport& r : report.holes) {
    EXPECT_TRUE(r.filled) << r.reason;
    ASSERT_FALSE(r.warnings.empty());
    EXPECT_NE(r.warnings.front().find("ring"), std::string::npos) << r.warnings.front();
    with_faces += r.new_faces.empty() ? 0 : 1;
    patch.insert(patch.end(), r.new_faces.begin(), r.new_faces.end());
  }
  EXPECT_EQ(with_faces, 1u);
  // The removed faces' area: the cells whose centroids lie in the ring, as the rims outline.
  double removed = 0;
  const MeshSoup sheet = testing::grid(16, 16);
  for (const Triangle& t : sheet.triangles) {
    const Vec3 c = (sheet.points[t[0]] + sheet.points[t[1]] + sheet.points[t[2]]) / 3;
    const double r = std::hypot(c[0] - 8, c[1] - 8);
    if (r > 2 && r < 4) removed += 0.5;
  }
  EXPECT_NEAR(area_of(mesh, patch), removed, 1e-6);
  for (const FaceHandle f : patch)
    for (const VertexHandle v : mesh.fv_range(f)) EXPECT_NEAR(mesh.point(v)[2], 0.0, 1e-9);
  EXPECT_EQ(find_holes(mesh).holes.size(), 1u);  // the grid's border
  EXPECT_TRUE(find_face_intersections(mesh, patch).empty());
}

//! A plate with a pocket or counterbore whose wall was cut has three loops: the plate's outer
//! border, the mouth's and the lower level's. The two small ones are one ring on two levels;
//! filled together, both close (the fill invariants kept) and \p patch gets their new faces.
void fill_the_two_levels(Mesh& mesh, std::vector<FaceHandle>& patch) {
  const std::vector<Hole> holes = find_holes(mesh).holes;
  ASSERT_EQ(holes.size(), 3u);
  std::vector<std::uint32_t> ids;
  std::vector<const Hole*> all;
  for (const Hole& h : holes) {
    all.push_back(&h);
    if (h.area < 20) ids.push_back(h.id);
  }
  ASSERT_EQ(ids.size(), 2u);
  EXPECT_EQ(find_ring_borders(mesh, all).size(), 1u);
  const testing::Snapshot before = testing::take_snapshot(mesh);
  const FillReport report =
      fill_holes(mesh, FillSelection{.mode = FillSelection::Mode::Ids, .ids = ids}, {});
  ASSERT_EQ(report.holes.size(), 2u);
  EXPECT_EQ(testing::check_fill_invariants(before, mesh, report.holes, holes), "");
  for (const HoleFillReport& r : report.holes) {
    EXPECT_TRUE(r.filled) << r.reason;
    patch.insert(patch.end(), r.new_faces.begin(), r.new_faces.end());
  }
}

// A pocket whose wall was cut (a slot along its rim's crease takes it on a CAD part): the
// plate's border around its mouth and the floor's border below it run opposite ways on two
// parallel planes. They are one ring on two levels, and the fill between them is the wall: every
// new face on the pocket's prism, as much area as was cut, neither level capped. With one
// triangle of the wall's upper row left standing (two corners on the mouth, one half-way down)
// the mouth's border dips down the wall and back: still the same ring.
void expect_the_wall_filled(bool keep_a_tooth) {
  constexpr int kAround = 24;
  constexpr double kRadius = 2.0, kDepth = 1.5;
  SCOPED_TRACE(keep_a_tooth ? "one wall triangle kept" : "the whole wall cut");
  const double step = 2 * std::numbers::pi / kAround;
  const Vec3 tooth =
      (Vec3(kRadius, 0, 0) + 2 * Vec3(kRadius * std::cos(step), kRadius * std::sin(step), 0) +
       Vec3(0, 0, -kDepth / 2)) /
      3;
  const auto in_the_wall = [&](const Vec3& c) {
    return c[2] < -1e-9 && c[2] > -kDepth + 1e-9 && !(keep_a_tooth && (c - tooth).norm() < 1e-9);
  };
  std::vector<std::array<Vec3, 3>> cut;
  Mesh mesh =
      build_mesh(testing::remove_faces(testing::plate_with_a_pocket(kAround, kRadius, kDepth, 2),
                                       in_the_wall, &cut))
          .mesh;
  ASSERT_EQ(cut.size(), 4u * kAround - (keep_a_tooth ? 1 : 0));
  std::vector<FaceHandle> patch;
  ASSERT_NO_FATAL_FAILURE(fill_the_two_levels(mesh, patch));
  ASSERT_FALSE(patch.empty());
  // On the prism: between the sides' chords and the circle, between the two levels.
  const double chord = kRadius * std::cos(std::numbers::pi / kAround);
  for (const FaceHandle f : patch)
    for (const VertexHandle v : mesh.fv_range(f)) {
      const Vec3& p = mesh.point(v);
      EXPECT_GE(std::hypot(p[0], p[1]), chord - 1e-9) << p;
      EXPECT_LE(std::hypot(p[0], p[1]), kRadius + 1e-9) << p;
      EXPECT_LE(p[2], 1e-9);
      EXPECT_GE(p[2], -kDepth - 1e-9);
    }
  double cut_area = 0;
  for (const auto& t : cut) cut_area += 0.5 * OpenMesh::cross(t[1] - t[0], t[2] - t[0]).norm();
  EXPECT_NEAR(area_of(mesh, patch), cut_area, 1e-3 * cut_area);
  EXPECT_EQ(find_holes(mesh).holes.size(), 1u);  // the plate's outer border
  EXPECT_TRUE(find_face_intersections(mesh, patch).empty());
}

TEST(RingBorders, APocketsCutWallIsFilledBetweenItsTwoLevels) {
  expect_the_wall_filled(false);
}

TEST(RingBorders, APocketsWallCutButForOneTriangleIsFilledBetweenItsTwoLevels) {
  expect_the_wall_filled(true);
}

// A counterbore whose wall and floor a slot took, and with them every other strip of the bore's
// wall below (couplingdown's walls are strips of long triangles): the floor's inner border is a
// comb, its gaps narrow notches. The comb's level is that of its teeth, so the mouth and the comb
// are one ring on two levels; the notches are closed with their ears (exactly the strips cut)
// before the join, and the rest of the patch spans the counterbore between the two levels. The
// bore is not capped.
TEST(RingBorders, ACombOnTheLowerLevelIsClosedByItsEarsAndJoined) {
  constexpr int kAround = 24;
  constexpr double kRadius = 2.0, kDepth = 0.5, kBoreRadius = 1.0, kBoreDepth = 4.5;
  const double strip_centroid_z = -(kBoreDepth + 2 * kDepth) / 3;  // two corners on top
  std::vector<std::array<Vec3, 3>> cut;
  Mesh mesh =
      build_mesh(
          testing::remove_faces(
              testing::plate_with_a_counterbore(kAround, kRadius, kDepth, kBoreRadius, kBoreDepth),
              [&](const Vec3& c) {
                return (c[2] < -1e-9 && c[2] > -kDepth + 1e-9) ||  // the wall
                       (std::abs(c[2] + kDepth) < 1e-9 &&
                        std::hypot(c[0], c[1]) > kBoreRadius) ||  // the floor
                       std::abs(c[2] - strip_centroid_z) < 1e-9;  // the bore's strips
              },
              &cut))
          .mesh;
  ASSERT_EQ(cut.size(), 5u * kAround);
  std::vector<FaceHandle> patch;
  ASSERT_NO_FATAL_FAILURE(fill_the_two_levels(mesh, patch));
  // Every strip cut from the bore's wall is back as an ear; every other new face lies between
  // the levels, around the bore's mouth (none caps it).
  const auto same_corners = [](const TrianglePoints& a, const std::array<Vec3, 3>& b) {
    for (const Vec3& p : a)
      if (std::none_of(b.begin(), b.end(), [&](const Vec3& q) { return (p - q).norm() < 1e-9; }))
        return false;
    return true;
  };
  std::size_t ears = 0;
  for (const TrianglePoints& t : face_triangles(mesh, patch)) {
    const bool ear = std::any_of(cut.begin(), cut.end(), [&](const std::array<Vec3, 3>& c) {
      return std::abs((c[0][2] + c[1][2] + c[2][2]) / 3 - strip_centroid_z) < 1e-9 &&
             same_corners(t, c);
    });
    if (ear) {
      ++ears;
      continue;
    }
    for (const Vec3& p : t) {
      EXPECT_LE(p[2], 1e-9);
      EXPECT_GE(p[2], -kDepth - 1e-9);
    }
    const Vec3 centroid = (t[0] + t[1] + t[2]) / 3;
    EXPECT_GT(std::hypot(centroid[0], centroid[1]),
              kBoreRadius * std::cos(std::numbers::pi / kAround) - 1e-9);
  }
  EXPECT_EQ(ears, static_cast<std::size_t>(kAround));
  EXPECT_EQ(find_holes(mesh).holes.size(), 1u);  // the plate's outer border
  EXPECT_TRUE(find_face_intersections(mesh, patch).empty());
}

// Only the outer border picked: it cannot be filled alone (its patch would lie on the island),
// and the reason names the inner border to fill with it.
TEST(RingBorders, OneBorderPickedAloneIsLeftOpenNamingTheOther) {
  Mesh mesh = build_mesh(grid_with_a_ring_cut()).mesh;
  const std::vector<Hole> holes = find_holes(mesh).holes;
  const Hole* outer = nullptr;
  const Hole* inner = nullptr;
  for (const Hole& h : holes)
    if (h.area < 60) (h.area > 30 ? outer : inner) = &h;
  ASSERT_TRUE(outer && inner);
  const std::size_t faces = mesh.n_faces();
  const FillReport report =
      fill_holes(mesh, FillSelection{.mode = FillSelection::Mode::Ids, .ids = {outer->id}}, {});
  ASSERT_EQ(report.holes.size(), 1u);
  EXPECT_FALSE(report.holes[0].filled);
  EXPECT_NE(report.holes[0].reason.find(fmt::format("hole {} borders the same ring", inner->id)),
            std::string::npos)
      << report.holes[0].reason;
  mesh.garbage_collection();
  EXPECT_EQ(mesh.n_faces(), faces);
}

}  // namespace
}  // namespace touchmend::geometry
