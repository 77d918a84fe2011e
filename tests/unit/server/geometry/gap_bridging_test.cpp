// Gap bridging (seed 000 §4.3): two registered plates with a gap between them, closed by
// stitches (Algorithm VIII) or by a stitch at each end and the hole filler (Algorithm IX);
// invalid stitches are refused and change nothing.

#include "server/geometry/gap_bridging.h"

#include <gtest/gtest.h>

#include "server/geometry/holes.h"
#include "server/geometry/mesh_build.h"
#include "server/geometry/mesh_intersections.h"
#include "server/geometry/mesh_io.h"
#include "server/geometry/metrics.h"
#include "tests/support/cases.h"
#include "tests/support/mesh_factory.h"

namespace touchmend::geometry {
namespace {

constexpr int kN = 4;  // cells per plate side

//! Plate L over [0, 4]² and plate R over [4.5, 8.5] x [0, 4], both facing +z (R flipped on
//! request): a straight gap of width 0.5 between x = 4 and x = 4.5.
Mesh two_plates(bool flip_right = false, bool wall = false) {
  MeshSoup soup = testing::two_plates(kN, 0.5);
  if (flip_right)
    for (std::size_t i = soup.triangles.size() / 2; i < soup.triangles.size(); ++i)
      std::swap(soup.triangles[i][1], soup.triangles[i][2]);
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

//! The cube [0, 8]³ with the band of faces between x = 3 and x = 4 removed all around: two
//! square boundary loops facing each other across a gap of one cell.
Mesh cube_with_band() {
  return build_mesh(testing::remove_faces(testing::cube(8),
                                          [](const Vec3& c) { return c[0] > 3 && c[0] < 4; }))
      .mesh;
}

//! The cube with a strip of the top face removed (3 < x < 4, 1 < y < 7): one long thin loop
//! whose two long sides face each other.
Mesh cube_with_strip() {
  return build_mesh(testing::remove_faces(testing::cube(8),
                                          [](const Vec3& c) {
                                            return c[0] > 3 && c[0] < 4 && c[1] > 1 && c[1] < 7 &&
                                                   c[2] > 7.9;
                                          }))
      .mesh;
}

void expect_closed_clean(const Mesh& mesh) {
  const ValidationReport report = validate_mesh(mesh);
  EXPECT_TRUE(report.is_clean()) << "non-manifold or inconsistent after bridging";
  EXPECT_TRUE(find_holes(mesh).holes.empty()) << "the mesh is not closed";
  EXPECT_TRUE(find_self_intersections(mesh).empty());
}

TEST(GapDetection, FindsTheBandAroundACubeAsOneCyclicGap) {
  const Mesh mesh = cube_with_band();
  const auto holes = find_holes(mesh).holes;
  ASSERT_EQ(holes.size(), 2u);
  const auto gaps = find_gaps(mesh, holes);
  ASSERT_EQ(gaps.size(), 1u);
  EXPECT_TRUE(gaps[0].cyclic);
  EXPECT_NE(gaps[0].hole_a, gaps[0].hole_b);
  EXPECT_EQ(gaps[0].run_a.size(), 32u);
  EXPECT_EQ(gaps[0].run_b.size(), 32u);
  EXPECT_NEAR(gaps[0].mean_width, 1.0, 1e-9);
  // Narrower than the band: nothing.
  GapOptions narrow;
  narrow.max_width = 0.5;
  EXPECT_TRUE(find_gaps(mesh, holes, narrow).empty());
}

TEST(GapDetection, AutomaticZipperClosesTheBand) {
  Mesh mesh = cube_with_band();
  const auto holes = find_holes(mesh).holes;
  const auto gaps = find_gaps(mesh, holes);
  ASSERT_EQ(gaps.size(), 1u);
  const ZipResult r = zip_gap(mesh, gaps[0]);
  ASSERT_TRUE(r.ok) << r.reason;
  EXPECT_EQ(r.faces.size(), 64u);  // 32 + 32 edges, one triangle each
  expect_closed_clean(mesh);
}

TEST(GapDetection, StripInOneLoopIsBridgedAutomaticallyManuallyAndSemiAutomatically) {
  {  // automatic: detection on one loop, zipper
    Mesh mesh = cube_with_strip();
    const auto holes = find_holes(mesh).holes;
    ASSERT_EQ(holes.size(), 1u);
    const auto gaps = find_gaps(mesh, holes);
    ASSERT_EQ(gaps.size(), 1u);
    EXPECT_EQ(gaps[0].hole_a, gaps[0].hole_b);
    EXPECT_FALSE(gaps[0].cyclic);
    const DetectedGapBridge r = bridge_detected_gap(mesh, gaps[0]);
    ASSERT_TRUE(r.zip.ok) << r.zip.reason;
    EXPECT_EQ(r.end_fills.size(), 2u);  // the two short ends of the strip
    for (const auto& f : r.end_fills) EXPECT_TRUE(f.filled) << f.reason;
    mesh.garbage_collection();
    expect_closed_clean(mesh);
  }
  // Vertex ids of the strip's two long sides, by position.
  const auto at = [](const Mesh& mesh, double x, double y) {
    for (const VertexHandle v : mesh.vertices())
      if ((mesh.point(v) - Vec3(x, y, 8)).norm() < 1e-9) return v;
    return VertexHandle();
  };
  {  // manual: Algorithm VIII stitches, two per cell
    Mesh mesh = cube_with_strip();
    for (int y = 1; y < 7; ++y) {
      const StitchResult a =
          stitch_triangle(mesh, at(mesh, 3, y), at(mesh, 3, y + 1), at(mesh, 4, y));
      ASSERT_TRUE(a.ok) << a.reason;
      const StitchResult b =
          stitch_triangle(mesh, at(mesh, 4, y), at(mesh, 4, y + 1), at(mesh, 3, y + 1));
      ASSERT_TRUE(b.ok) << b.reason;
    }
    expect_closed_clean(mesh);
  }
  {  // semi-automatic: Algorithm IX, a stitch at each end, the hole filler for the rest
    Mesh mesh = cube_with_strip();
    const GapBridgeResult r = bridge_gap(mesh, {at(mesh, 3, 1), at(mesh, 3, 2), at(mesh, 4, 1)},
                                         {at(mesh, 4, 6), at(mesh, 4, 7), at(mesh, 3, 7)});
    ASSERT_TRUE(r.ok) << r.reason;
    mesh.garbage_collection();
    expect_closed_clean(mesh);
  }
}

TEST(GapDetection, PlatesGapIsFoundAndZipped) {
  Mesh mesh = two_plates();
  const auto holes = find_holes(mesh).holes;
  const auto gaps = find_gaps(mesh, holes);
  ASSERT_EQ(gaps.size(), 1u);
  EXPECT_EQ(gaps[0].run_a.size(), static_cast<std::size_t>(kN + 1));
  EXPECT_NEAR(gaps[0].max_width, 0.5, 1e-9);
  const ZipResult r = zip_gap(mesh, gaps[0]);
  ASSERT_TRUE(r.ok) << r.reason;
  expect_clean_single_boundary(mesh);
}

// A band cut through a curved surface does not face itself all round: detection finds several
// runs, and the narrow pieces between them are closed after the zippers.
TEST(GapDetection, ABandThroughACurvedMeshIsClosedWhole) {
  for (const char* name : {"sphere966.off", "spot.obj"}) {
    SCOPED_TRACE(name);
    const ReadResult read = read_mesh_file(testing::shared_data_dir() + "/meshes/" + name);
    ASSERT_TRUE(read.ok) << read.error;
    Mesh mesh = build_mesh(testing::cut_band(read.soup, 1.2)).mesh;
    const auto holes = find_holes(mesh).holes;
    ASSERT_EQ(holes.size(), 2u);  // the two sides of the band
    const auto gaps = find_gaps(mesh, holes);
    ASSERT_GE(gaps.size(), 2u);
    std::vector<const Gap*> all;
    for (const Gap& g : gaps) all.push_back(&g);
    const std::size_t faces_before = mesh.n_faces();
    const DetectedGapsBridge r = bridge_detected_gaps(mesh, all);
    EXPECT_EQ(r.bridged(), gaps.size());
    EXPECT_FALSE(r.leftover_fills.empty());  // the zippers alone leave pieces of the band
    for (const auto& f : r.leftover_fills) EXPECT_TRUE(f.filled) << f.reason;
    std::vector<FaceHandle> added;
    for (std::size_t f = faces_before; f < mesh.n_faces(); ++f)
      if (!mesh.status(FaceHandle(static_cast<int>(f))).deleted())
        added.push_back(FaceHandle(static_cast<int>(f)));
    EXPECT_TRUE(find_face_intersections(mesh, added, 1, max_edge_length(mesh)).empty());
    mesh.garbage_collection();
    expect_closed_clean(mesh);
  }
}

TEST(GapDetection, ZipperThroughAWallIsRefusedAndTakenBack) {
  Mesh mesh = two_plates(false, true);
  const auto holes = find_holes(mesh).holes;
  const auto gaps = find_gaps(mesh, holes);
  ASSERT_FALSE(gaps.empty());
  const std::size_t faces = mesh.n_faces();
  const ZipResult r = zip_gap(mesh, gaps[0]);
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.reason.find("intersect"), std::string::npos) << r.reason;
  mesh.garbage_collection();
  EXPECT_EQ(mesh.n_faces(), faces);
}

}  // namespace
}  // namespace touchmend::geometry
