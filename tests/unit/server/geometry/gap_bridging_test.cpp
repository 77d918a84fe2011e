// Gap bridging (seed 000 §4.3): two registered plates with a gap between them, closed by
// stitches (Algorithm VIII) or by a stitch at each end and the hole filler (Algorithm IX);
// invalid stitches are refused and change nothing.

#include "server/geometry/gap_bridging.h"

#include <gtest/gtest.h>

#include "server/geometry/holes.h"
#include "server/geometry/mesh_build.h"
#include "server/geometry/mesh_intersections.h"
#include "server/geometry/metrics.h"
#include "tests/support/mesh_factory.h"

namespace touchmend::geometry {
namespace {

constexpr int kN = 4;  // cells per plate side

//! Plate L over [0, 4]² and plate R over [4.5, 8.5] x [0, 4], both facing +z (R flipped on
//! request): a straight gap of width 0.5 between x = 4 and x = 4.5.
Mesh two_plates(bool flip_right = false, bool wall = false) {
  MeshSoup soup = testing::grid(kN, kN);
  const MeshSoup right = testing::grid(kN, kN);
  const auto offset = static_cast<std::uint32_t>(soup.points.size());
  for (const Vec3& p : right.points) soup.points.push_back(p + Vec3(kN + 0.5, 0, 0));
  for (auto t : right.triangles) {
    if (flip_right) std::swap(t[1], t[2]);
    soup.triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
  }
  if (wall) {  // a vertical sheet standing in the gap at x = 4.25
    const auto w = static_cast<std::uint32_t>(soup.points.size());
    for (const Vec3& p : {Vec3(kN + 0.25, -1, -1), Vec3(kN + 0.25, kN + 1, -1),
                          Vec3(kN + 0.25, kN + 1, 1), Vec3(kN + 0.25, -1, 1)})
      soup.points.push_back(p);
    soup.triangles.push_back({w, w + 1, w + 2});
    soup.triangles.push_back({w, w + 2, w + 3});
  }
  return build_mesh(soup).mesh;
}

VertexHandle left(int x, int y) {
  return VertexHandle(y * (kN + 1) + x);
}
VertexHandle right(int x, int y) {
  return VertexHandle((kN + 1) * (kN + 1) + y * (kN + 1) + x);
}

void expect_clean_single_boundary(const Mesh& mesh) {
  const ValidationReport report = validate_mesh(mesh);
  EXPECT_TRUE(report.is_clean()) << "non-manifold or inconsistent after bridging";
  EXPECT_EQ(find_holes(mesh).holes.size(), 1u);  // only the outer boundary is left
  EXPECT_TRUE(find_self_intersections(mesh).empty());
  for (const FaceHandle f : mesh.faces()) EXPECT_GT(mesh.calc_face_normal(f)[2], 0.99);
}

TEST(GapBridging, ManualStitchesZipTheGapClosed) {
  Mesh mesh = two_plates();
  ASSERT_EQ(find_holes(mesh).holes.size(), 2u);
  for (int y = 0; y < kN; ++y) {
    const StitchResult a = stitch_triangle(mesh, left(kN, y), left(kN, y + 1), right(0, y));
    ASSERT_TRUE(a.ok) << a.reason;
    const StitchResult b = stitch_triangle(mesh, right(0, y), right(0, y + 1), left(kN, y + 1));
    ASSERT_TRUE(b.ok) << b.reason;
  }
  expect_clean_single_boundary(mesh);
}

TEST(GapBridging, InvalidStitchesAreRefusedAndChangeNothing) {
  Mesh mesh = two_plates();
  const std::size_t faces = mesh.n_faces();
  const auto refused = [&](VertexHandle a, VertexHandle b, VertexHandle t, const char* why) {
    const StitchResult r = stitch_triangle(mesh, a, b, t);
    EXPECT_FALSE(r.ok) << why;
    EXPECT_NE(r.reason.find(why), std::string::npos) << r.reason;
    EXPECT_EQ(mesh.n_faces(), faces);
  };
  refused(left(1, 1), left(2, 1), right(0, 1), "not a boundary edge");  // interior edge
  refused(left(kN, 0), left(kN, 1), right(2, 2), "not on a boundary");  // interior target
  refused(left(kN, 0), left(kN, 1), left(kN, 2), "degenerate");         // collinear
  refused(left(kN, 0), left(kN, 1), left(kN, 0), "different");
  refused(left(kN, 0), left(kN, 1), VertexHandle(100000), "does not exist");
  Mesh walled = two_plates(false, true);
  const StitchResult through = stitch_triangle(walled, left(kN, 1), left(kN, 2), right(0, 1));
  EXPECT_FALSE(through.ok);
  EXPECT_NE(through.reason.find("intersect"), std::string::npos) << through.reason;
  Mesh flipped = two_plates(true);
  const StitchResult r = stitch_triangle(flipped, left(kN, 0), left(kN, 1), right(0, 0));
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.reason.find("opposite orientations"), std::string::npos) << r.reason;
  // A stitch whose other edge would get a second face on the same side.
  ASSERT_TRUE(stitch_triangle(mesh, left(kN, 0), left(kN, 1), right(0, 0)).ok);
  const StitchResult again = stitch_triangle(mesh, right(0, 0), right(0, 1), left(kN, 0));
  EXPECT_FALSE(again.ok);
}

TEST(GapBridging, SemiAutomaticClosesTheEndsAndFillsTheGap) {
  Mesh mesh = two_plates();
  const GapBridgeResult r = bridge_gap(mesh, {left(kN, 0), left(kN, 1), right(0, 0)},
                                       {left(kN, kN - 1), left(kN, kN), right(0, kN)});
  ASSERT_TRUE(r.ok) << r.reason;
  ASSERT_EQ(r.stitches.size(), 2u);
  ASSERT_EQ(r.fills.size(), 1u);
  EXPECT_GT(r.fills[0].faces_added, 0u);
  mesh.garbage_collection();
  expect_clean_single_boundary(mesh);
  for (const VertexHandle v : mesh.vertices()) EXPECT_NEAR(mesh.point(v)[2], 0.0, 1e-9);  // flat
  // A refused second end takes the first stitch back.
  Mesh other = two_plates();
  const GapBridgeResult bad = bridge_gap(other, {left(kN, 0), left(kN, 1), right(0, 0)},
                                         {left(1, 1), left(2, 1), right(0, kN)});
  EXPECT_FALSE(bad.ok);
  EXPECT_NE(bad.reason.find("second end"), std::string::npos);
  other.garbage_collection();
  EXPECT_EQ(other.n_faces(), two_plates().n_faces());
}

}  // namespace
}  // namespace touchmend::geometry
