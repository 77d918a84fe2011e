#include "server/geometry/hole_filling.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <numbers>
#include <random>
#include <span>
#include <string>
#include <string_view>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "server/geometry/mesh_build.h"
#include "server/geometry/mesh_intersections.h"
#include "server/geometry/mesh_io.h"
#include "server/geometry/metrics.h"
#include "tests/support/cases.h"
#include "tests/support/invariants.h"
#include "tests/support/mesh_factory.h"

namespace touchmend::geometry {
namespace {

using testing::check_fill_invariants;
using testing::remove_faces;
using testing::take_snapshot;

//! Builds the mesh, fills the holes chosen by \p pick (all but the largest by default: the
//! synthetic open meshes have an outer border that must stay), checks every invariant.
struct FillRun {
  Mesh mesh;
  std::vector<Hole> holes;
  std::vector<HoleFillReport> reports;
};

FillRun fill_and_check(const MeshSoup& soup, const FillOptions& options,
                       const std::function<bool(const Hole&)>& pick) {
  FillRun run{build_mesh(soup).mesh, {}, {}};
  run.holes = find_holes(run.mesh).holes;
  const testing::Snapshot before = take_snapshot(run.mesh);
  for (const Hole& h : run.holes)
    if (pick(h)) run.reports.push_back(fill_hole(run.mesh, h, options));
  const std::string problems = check_fill_invariants(before, run.mesh, run.reports, run.holes);
  EXPECT_TRUE(problems.empty()) << problems;
  return run;
}

//! A shared mesh with the faces whose centroids lie in any of \p balls (centre, radius)
//! removed, as touchmend-cut-bench cuts it (its --only prints a cut's balls). Empty when the
//! mesh cannot be read (the test then fails).
//! The removed faces go to \p removed when given.
MeshSoup cut_shared_mesh(const std::string& name, std::span<const std::pair<Vec3, double>> balls,
                         std::vector<TrianglePoints>* removed = nullptr) {
  const ReadResult read = read_mesh_file(testing::shared_data_dir() + "/meshes/" + name);
  EXPECT_TRUE(read.ok) << read.error;
  if (!read.ok) return {};
  return remove_faces(
      read.soup,
      [&](const Vec3& c) {
        return std::any_of(balls.begin(), balls.end(),
                           [&](const auto& b) { return (c - b.first).norm() < b.second; });
      },
      removed);
}

//! The mean distance from the new faces of \p report to \p truth (the faces a cut removed),
//! over \p diagonal (the mesh's bounding-box diagonal).
double mean_distance_to(const FillRun& run, const HoleFillReport& report,
                        const std::vector<TrianglePoints>& truth, double diagonal) {
  return surface_distance(face_triangles(run.mesh, report.new_faces), truth, 1e-3 * diagonal)
             .mean_a_to_b /
         diagonal;
}

//! \p run filled its one hole flat with the 3D triangulation, crossing nothing, and the shape
//! reason says \p how (when not empty).
void expect_clean_3d_fill(const FillRun& run, std::string_view how) {
  ASSERT_EQ(run.reports.size(), 1u);
  const HoleFillReport& r = run.reports[0];
  ASSERT_TRUE(r.filled) << r.reason;
  EXPECT_EQ(r.method, FillMethod::MinimumWeight3d);
  EXPECT_EQ(r.shape, PatchShape::Flat) << r.shape_reason;
  if (!how.empty()) {
    EXPECT_NE(r.shape_reason.find(how), std::string::npos) << r.shape_reason;
  }
  EXPECT_TRUE(find_face_intersections(run.mesh, r.new_faces, 1).empty());
}

//! \p run left its one hole open, saying \p why.
void expect_left_open(const FillRun& run, std::string_view why) {
  ASSERT_EQ(run.reports.size(), 1u);
  EXPECT_FALSE(run.reports[0].filled);
  EXPECT_NE(run.reports[0].reason.find(why), std::string::npos) << run.reports[0].reason;
}

//! \p run filled its one hole by a crease split along \p curves of the \p planned curves of its
//! plan (the split along them all could not be made), crossing nothing.
void expect_split_along_fewer_curves(const FillRun& run, std::size_t curves, std::size_t planned) {
  ASSERT_EQ(run.reports.size(), 1u);
  const HoleFillReport& r = run.reports[0];
  ASSERT_TRUE(r.filled) << r.reason;
  EXPECT_EQ(r.method, FillMethod::CreaseSplit) << r.shape_reason;
  EXPECT_EQ(r.crease_curves, curves) << r.creases;
  const std::string whole = fmt::format("the split along all {} curves of the plan", planned);
  EXPECT_NE(r.shape_reason.find(whole), std::string::npos) << r.shape_reason;
  EXPECT_TRUE(find_face_intersections(run.mesh, r.new_faces, 1).empty());
}

double min_new_angle(const FillRun& run) {
  double a = 180;
  for (const auto& r : run.reports)
    a = std::min(a, triangle_quality(face_triangles(run.mesh, r.new_faces)).min_angle_deg);
  return a;
}

TEST(FillHole, PlanarHoleInAGridStaysExactlyPlanar) {
  const MeshSoup s = testing::grid_with_round_hole();
  const FillRun run = fill_and_check(s, {}, [](const Hole& h) { return h.loop.size() < 64; });
  ASSERT_EQ(run.reports.size(), 1u);
  const HoleFillReport& r = run.reports[0];
  ASSERT_TRUE(r.filled) << r.reason;
  EXPECT_EQ(r.method, FillMethod::Planar);
  EXPECT_EQ(r.shape, PatchShape::Flat);
  EXPECT_GT(r.vertices_added, 0u);
  EXPECT_GT(r.angles_closed, 0u);
  for (const auto v : r.new_vertices) EXPECT_EQ(run.mesh.point(v)[2], 0.0);
  EXPECT_GT(min_new_angle(run), 15.0);
}

TEST(FillHole, HoleOnACylinderIsFairedBackOntoIt) {
  const MeshSoup s = remove_faces(testing::cylinder(1.0, 4.0, 48, 25),
                                  [](const Vec3& c) { return (c - Vec3(1, 0, 2)).norm() < 0.7; });
  const FillRun run = fill_and_check(s, {}, [](const Hole& h) { return h.loop.size() < 48; });
  ASSERT_EQ(run.reports.size(), 1u);
  const HoleFillReport& r = run.reports[0];
  ASSERT_TRUE(r.filled) << r.reason;
  EXPECT_EQ(r.shape, PatchShape::Fair) << r.shape_reason;
  double worst = 0;
  for (const auto v : r.new_vertices) {
    const Vec3 p = run.mesh.point(v);
    worst = std::max(worst, std::abs(std::hypot(p[0], p[1]) - 1.0));
  }
  EXPECT_LT(worst, 0.02);
  EXPECT_GE(min_new_angle(run), 15.0);  // DESIGN's goal for refined fills
  // The report and the metrics module compute the angle by different formulas.
  EXPECT_NEAR(r.min_angle_deg, min_new_angle(run), 1e-9);
}

TEST(FillHole, HoleOnASphereIsFairedBackOntoIt) {
  const MeshSoup s =
      remove_faces(testing::uv_sphere(1.0, 48, 32), [](const Vec3& c) { return c[0] > 0.8; });
  const FillRun run = fill_and_check(s, {}, [](const Hole&) { return true; });
  ASSERT_EQ(run.reports.size(), 1u);
  const HoleFillReport& r = run.reports[0];
  ASSERT_TRUE(r.filled) << r.reason;
  EXPECT_EQ(r.shape, PatchShape::Fair);
  EXPECT_EQ(r.fair_base, "sphere");
  EXPECT_NE(r.shape_reason.find("continues the sphere"), std::string::npos) << r.shape_reason;
  const auto worst_radius_error = [](const FillRun& fill) {
    double worst = 0;
    for (const auto v : fill.reports.at(0).new_vertices)
      worst = std::max(worst, std::abs(fill.mesh.point(v).norm() - 1.0));
    return worst;
  };
  // On the sphere, but for the bump that puts the patch's triangles at the surroundings' mean
  // offset from it (FairingOptions::match_facet_offset): off 1 by less than the sag of the
  // patch's longest edge; the plain thin plate sags inside it (measured: 0.012).
  double longest = 0;
  for (const FaceHandle g : r.new_faces)
    for (const auto h : run.mesh.fh_range(g))
      longest = std::max(longest, run.mesh.calc_edge_length(h));
  const double worst = worst_radius_error(run);
  EXPECT_LT(worst, longest * longest / 8);
  FillOptions plain;
  plain.fairing.base_fit_rings = 0;
  const FillRun plain_run = fill_and_check(s, plain, [](const Hole&) { return true; });
  EXPECT_TRUE(plain_run.reports.at(0).fair_base.empty());
  EXPECT_GT(worst_radius_error(plain_run), 1e-3);
  EXPECT_GE(min_new_angle(run), 15.0);
  // Flat would be far off, even against the plain thin plate: the fair decision matters.
  FillOptions flat;
  flat.shape = PatchShape::Flat;
  const FillRun flat_run = fill_and_check(s, flat, [](const Hole&) { return true; });
  EXPECT_GT(worst_radius_error(flat_run), 3 * worst_radius_error(plain_run));
}

// A cube with its whole top face cut away: the walls around the hole turn by 90 deg, so the
// auto shape asks for fairing, but the four-corner hole has no vertex to fair and the patch is
// flat. The report says that the faired shape was refused, not only why it was chosen.
TEST(FillHole, AFlatFallbackSaysTheFairedShapeWasRefused) {
  const MeshSoup s = remove_faces(testing::cube(1), [](const Vec3& c) { return c[2] > 0.99; });
  const FillRun run = fill_and_check(s, {}, [](const Hole&) { return true; });
  ASSERT_EQ(run.reports.size(), 1u);
  const HoleFillReport& r = run.reports[0];
  ASSERT_TRUE(r.filled) << r.reason;
  EXPECT_EQ(r.shape, PatchShape::Flat) << r.shape_reason;
  EXPECT_EQ(r.faces_added, 2u);
  EXPECT_NE(r.shape_reason.find("was refused"), std::string::npos) << r.shape_reason;
  ASSERT_FALSE(r.warnings.empty());
  EXPECT_NE(r.warnings.front().find("filled flat instead"), std::string::npos) << r.warnings[0];
}

// A ball cut through spot's neck leaves a 14-edge hole whose thin plate is refused; the flat
// stand-in over its bent rim keeps folds that no move within its surface mends (11.5°). The
// membrane over the same triangulation is mended in 3D to DESIGN's 15° (21.0°), and stays near
// the removed surface.
TEST(FillHole, AFlatStandInUnder15DegreesGivesWayToAMembrane) {
  const ReadResult read = read_mesh_file(testing::shared_data_dir() + "/meshes/spot.obj");
  ASSERT_TRUE(read.ok) << read.error;
  const Vec3 centre(0.0439995, -0.453929, 0.682063);
  std::vector<TrianglePoints> truth;  // the removed faces
  const MeshSoup cut = remove_faces(
      read.soup, [&](const Vec3& c) { return (c - centre).norm() < 0.340663462; }, &truth);
  const auto small_hole = [](const Hole& h) { return h.loop.size() == 14; };
  const FillRun run = fill_and_check(cut, {}, small_hole);
  ASSERT_EQ(run.reports.size(), 1u);
  const HoleFillReport& r = run.reports[0];
  ASSERT_TRUE(r.filled) << r.reason;
  EXPECT_EQ(r.shape, PatchShape::Fair);
  EXPECT_EQ(r.shape_reason.rfind("a membrane", 0), 0u) << r.shape_reason;
  EXPECT_GE(min_new_angle(run), 15.0);
  EXPECT_TRUE(find_face_intersections(run.mesh, r.new_faces, 1).empty());
  const double diagonal = 2.5881;  // spot's bounding-box diagonal
  const SurfaceDistance d =
      surface_distance(face_triangles(run.mesh, r.new_faces), truth, 1e-3 * diagonal);
  EXPECT_LT(d.mean_a_to_b, 0.015 * diagonal);

  FillOptions flat_only;
  flat_only.membrane_fallback = false;
  const FillRun flat = fill_and_check(cut, flat_only, small_hole);
  ASSERT_EQ(flat.reports.size(), 1u);
  ASSERT_TRUE(flat.reports[0].filled) << flat.reports[0].reason;
  EXPECT_EQ(flat.reports[0].shape, PatchShape::Flat);
  EXPECT_LT(min_new_angle(flat), 15.0);
}

// Two balls cut out of the bunny's flank (touchmend-cut-bench --max-radius 0.3 --only
// stanford-bunny.obj:3:7) leave a 410-edge hole, over the 3D triangulation's 400-vertex limit,
// whose planar and piecewise patches and ear clipping all cross the mesh. The 3D
// triangulation of all 410 vertices closes it as a last resort.
TEST(FillHole, AHoleOverTheTriangulationLimitThatNothingElseClosesGetsItAsALastResort) {
  const std::array<std::pair<Vec3, double>, 2> balls{
      {{Vec3(-0.079272, 0.107765, 0.032001), 0.0149707959},
       {Vec3(-0.057745, 0.076784, -0.019116), 0.0534781316}}};
  const MeshSoup cut = cut_shared_mesh("stanford-bunny.obj", balls);
  const auto large_hole = [](const Hole& h) { return h.loop.size() == 410; };
  const FillRun run = fill_and_check(cut, {}, large_hole);
  ASSERT_EQ(run.reports.size(), 1u);
  const HoleFillReport& r = run.reports[0];
  ASSERT_TRUE(r.filled) << r.reason;
  EXPECT_EQ(r.method, FillMethod::MinimumWeight3d);
  ASSERT_FALSE(r.warnings.empty());
  EXPECT_NE(r.warnings.back().find("a last resort"), std::string::npos) << r.warnings.back();
  // It comes before the flat patches built again with less mending (their slivers would win).
  EXPECT_EQ(r.warnings.back().find("(again, its folds kept)"), std::string::npos)
      << r.warnings.back();
  EXPECT_TRUE(find_face_intersections(run.mesh, r.new_faces, 1).empty());
  EXPECT_GE(min_new_angle(run), 15.0);

  FillOptions no_last_resort;
  no_last_resort.last_resort_dp_vertices = 0;
  expect_left_open(fill_and_check(cut, no_last_resort, large_hole), "exceed its limit of 400");
}

// Two balls cut out of the coupling (touchmend-cut-bench --only couplingdown.off:5:2) leave a
// 33-edge hole: strips cut out of the outer wall above its floor, every other strip triangle
// left standing (a comb). Next to the wall's creases the shape is faired, but the 3D
// triangulation (wall and floor, as the removed faces were) has no vertex of its own to fair,
// and the planar triangulation faired after it lay 105.9 per mille of the diagonal off the
// removed faces. The 3D triangulation's flat build now comes right after. (By default the
// comb's gaps are closed with their ears first, and the rest is split along the wall's foot,
// 1.25 per mille off; the test fills without, to reach the whole-hole attempts it is about.)
TEST(FillHole, ANearCreaseTriangulationWithNothingToFairIsKeptFlatBeforeOtherFairedPatches) {
  const std::array<std::pair<Vec3, double>, 2> balls{
      {{Vec3(0.397057, -0.123474, -0.18239), 0.138565933},
       {Vec3(-0.232609, -0.285064, 0.157233), 0.191125384}}};
  std::vector<TrianglePoints> truth;
  const MeshSoup cut = cut_shared_mesh("couplingdown.off", balls, &truth);
  const auto comb_hole = [](const Hole& h) { return h.loop.size() == 33; };
  FillOptions no_notches;
  no_notches.close_notches = false;
  const FillRun run = fill_and_check(cut, no_notches, comb_hole);
  expect_clean_3d_fill(run, "");
  ASSERT_EQ(run.reports.size(), 1u);
  const double diagonal = 1.4605;  // couplingdown's bounding-box diagonal (rounded)
  EXPECT_LT(mean_distance_to(run, run.reports[0], truth, diagonal), 3e-3);
}

// Four balls cut out of the coupling (touchmend-cut-bench --only couplingdown.off:5:6) leave a
// 26-edge hole across the foot of the outer wall, its rim a comb of strip triangles hanging
// from the wall's top row (pinch_closing.h: close_notches). The gaps between the teeth are the
// rim's narrowest corners (8.6°); filled as part of the hole, their slivers were split and
// faired off the wall, 60.6 per mille of the diagonal off the removed faces on average. Closed
// with their ears first, the triangles the cut took, the rest is split along the wall's foot.
TEST(FillHole, TheGapsOfACombAreClosedWithTheTrianglesTheCutTook) {
  const std::array<std::pair<Vec3, double>, 4> balls{
      {{Vec3(0.0745276, 0.486462, -0.18239), 0.177907014},
       {Vec3(0.111206, 0.0172118, 0.0283019), 0.195611643},
       {Vec3(0.0444798, -0.373775, -0.174528), 0.137983138},
       {Vec3(-0.0659946, 0.271361, 0.0546324), 0.116585216}}};
  std::vector<TrianglePoints> truth;
  const MeshSoup cut = cut_shared_mesh("couplingdown.off", balls, &truth);
  const auto comb_hole = [](const Hole& h) { return h.id == 101 && h.loop.size() == 26; };
  const FillRun run = fill_and_check(cut, {}, comb_hole);
  ASSERT_EQ(run.reports.size(), 1u);
  const HoleFillReport& r = run.reports[0];
  ASSERT_TRUE(r.filled) << r.reason;
  EXPECT_GE(r.angles_closed, 4u);  // the four gaps between the five teeth
  EXPECT_TRUE(find_face_intersections(run.mesh, r.new_faces).empty());
  const double diagonal = 1.4605;  // couplingdown's bounding-box diagonal (rounded)
  EXPECT_LT(mean_distance_to(run, r, truth, diagonal), 5e-3);
}

// Five balls cut out of the coupling (touchmend-cut-bench --only couplingdown.off:1:6) leave a
// 26-edge hole across the foot of a wall, its rim a comb of strip triangles hanging from the
// wall's top row, next to another hole's rim. The 3D triangulation is clean, but its mending
// across the folds (the stand-in of the refused faired patch) flips an edge through a face of
// that rim, and every other attempt crosses the mesh too: the flat 3D triangulation is built
// again with its folds kept, and the hole is closed. (The rim also crosses a fillet at both
// ends, which the crease plan splits along since rounded creases are found: closed at 2.7°,
// mean 2.26 per mille off the removed faces against 6.6° and 1.03 this way. The test fills
// without crease retaining, to reach the whole-hole attempts it is about.)
TEST(FillHole, AFlatPatchWhoseMendingAcrossFoldsCrossesTheMeshIsBuiltAgainWithItsFoldsKept) {
  const std::array<std::pair<Vec3, double>, 5> balls{
      {{Vec3(-0.0162827, -0.478988, -0.174528), 0.197601784},
       {Vec3(-0.143505, -0.221517, -0.028951), 0.206316095},
       {Vec3(-0.0660867, 0.234673, -0.028951), 0.100110516},
       {Vec3(0.0264997, 0.440472, -0.0628931), 0.198419371},
       {Vec3(-0.232812, -0.166766, -0.0330189), 0.183701221}}};
  const MeshSoup cut = cut_shared_mesh("couplingdown.off", balls);
  const auto comb_hole = [](const Hole& h) { return h.id == 307 && h.loop.size() == 26; };
  FillOptions no_creases;
  no_creases.sharp = SharpMode::Off;
  const FillRun run = fill_and_check(cut, no_creases, comb_hole);
  expect_clean_3d_fill(run, "folds kept");
  ASSERT_EQ(run.reports.size(), 1u);
  EXPECT_GT(run.reports[0].min_angle_deg, 1.0);
}

// Even with its folds kept, the mending's moves and splits bring two of a patch's own
// triangles together where the rim folds tightly over itself: two balls cut out of the shark
// (touchmend-cut-bench --only mech-holes-shark.off:4:6) leave a 162-edge hole whose every
// patch crosses the mesh or itself. The avoiding 3D triangulation is clean, and built again
// without mending (the refined triangulation, on the same surface) it closes the hole.
TEST(FillHole, AFlatPatchThatCrossesTheMeshEvenWithItsFoldsKeptIsBuiltAgainUnmended) {
  const std::array<std::pair<Vec3, double>, 2> balls{
      {{Vec3(0.376222998, 0.0702892989, 0.0466743), 0.189236906},
       {Vec3(0.397763997, 0.178856, 0.212134004), 0.202167484}}};
  const MeshSoup cut = cut_shared_mesh("mech-holes-shark.off", balls);
  const auto folded_hole = [](const Hole& h) { return h.loop.size() == 162; };
  expect_clean_3d_fill(fill_and_check(cut, {}, folded_hole), "not mended");
}

// Three balls cut out of the coupling (touchmend-cut-bench --only couplingdown.off:1:7) leave
// a 112-edge hole around a lone triangle the cut left standing (a fragment). Every patch but
// the avoiding 3D triangulation crosses the mesh, and that one clears it only after many
// rounds, each forbidding the triangles that still cross; a round after the first solves
// only the intervals around them, so the rounds are bounded by their work, not a count.
TEST(FillHole, TheAvoiding3dTriangulationGetsTheRoundsItsWorkBudgetAllows) {
  const std::array<std::pair<Vec3, double>, 3> balls{
      {{Vec3(-0.0471691, -0.196202, 0.0534591), 0.206203909},
       {Vec3(0.148496, -0.097979, -0.174528), 0.105745664},
       {Vec3(-0.313944, -0.110366, 0.0546324), 0.0796876764}}};
  const MeshSoup cut = cut_shared_mesh("couplingdown.off", balls);
  const auto around_fragment = [](const Hole& h) { return h.loop.size() == 112; };
  expect_clean_3d_fill(fill_and_check(cut, {}, around_fragment), "");

  // With 8 rounds (and the last resort's 4 more, with the fans) it stays open.
  FillOptions eight_rounds;
  eight_rounds.max_avoiding_rounds = 8;
  expect_left_open(fill_and_check(cut, eight_rounds, around_fragment),
                   "after 12 rounds that forbade the triangles crossing the mesh (and the fans");
}

// Two balls cut out of fandisk's top (touchmend-cut-bench --only fandisk.obj:6:5) leave a
// 95-edge hole that two creases cross, each a convex edge that runs along a rim edge before it
// enters the hole. Such crossings used to pair only along an arc or a chord they both lie on;
// these creases fit neither, so all four crossings were left unmatched and the 3D
// triangulation folded across the creases (3.0° slivers, 11.0‰ of the diagonal from the
// removed faces). Paired by Hermite curves, the split keeps both creases.
TEST(FillHole, CreasesThatRunAlongTheRimFirstArePairedByHermiteCurves) {
  const std::array<std::pair<Vec3, double>, 2> balls{
      {{Vec3(2.79692, 16.122801, 0), 0.349043732}, {Vec3(2.42129, 16.3468, 0), 0.87998747}}};
  std::vector<TrianglePoints> truth;
  const MeshSoup cut = cut_shared_mesh("fandisk.obj", balls, &truth);
  const auto top_hole = [](const Hole& h) { return h.loop.size() == 95; };
  const FillRun run = fill_and_check(cut, {}, top_hole);
  ASSERT_EQ(run.reports.size(), 1u);
  const HoleFillReport& r = run.reports[0];
  ASSERT_TRUE(r.filled) << r.reason;
  EXPECT_EQ(r.method, FillMethod::CreaseSplit) << r.creases;
  EXPECT_EQ(r.crease_curves, 2u) << r.creases;
  EXPECT_EQ(r.creases.find("unmatched"), std::string::npos) << r.creases;
  EXPECT_GE(r.min_angle_deg, 15.0);
  EXPECT_TRUE(find_face_intersections(run.mesh, r.new_faces, 1).empty());
  const double diagonal = 7.6156;  // fandisk's bounding-box diagonal (rounded)
  EXPECT_LT(mean_distance_to(run, r, truth, diagonal), 1e-3);
}

// Four balls cut out of the coupling (touchmend-cut-bench --only couplingdown.off:7:1) leave a
// 34-edge hole whose plan joins four crease curves. The split along all four, and along the
// three left without the least certain, crosses the mesh; along the two most certain it is
// made. Without those retries the hole went to the whole-hole methods, whose faired 3D
// triangulation lay 54.6‰ of the diagonal from the removed faces on average.
TEST(FillHole, ACreaseSplitThatCannotBeMadeIsTriedAgainWithFewerCurves) {
  const std::array<std::pair<Vec3, double>, 4> balls{
      {{Vec3(0.0319323, -0.214538, -0.174528), 0.199290607},
       {Vec3(-0.0325057, -0.40641, 0.157233), 0.171796814},
       {Vec3(0.471698, 0, -0.174528), 0.210126349},
       {Vec3(0.112817, -0.19864, 0.0534591), 0.0950789782}}};
  std::vector<TrianglePoints> truth;
  const MeshSoup cut = cut_shared_mesh("couplingdown.off", balls, &truth);
  const auto hole_344 = [](const Hole& h) { return h.id == 344 && h.loop.size() == 34; };
  const double diagonal = 1.4605;  // the coupling's bounding-box diagonal (rounded)
  // Without closing the narrow gaps of its rim first (FillOptions::close_notches): by default
  // they are, and the split along three curves is made at once, 1.32 per mille off the removed
  // faces; the retry is what the test is about.
  FillOptions no_notches;
  no_notches.close_notches = false;
  const FillRun run = fill_and_check(cut, no_notches, hole_344);
  ASSERT_NO_FATAL_FAILURE(expect_split_along_fewer_curves(run, 2, 4));
  const HoleFillReport& r = run.reports[0];
  ASSERT_FALSE(r.warnings.empty());
  EXPECT_NE(r.warnings.back().find("crease-split (3 of 4 curves)"), std::string::npos)
      << r.warnings.back();
  EXPECT_LT(mean_distance_to(run, r, truth, diagonal), 0.005);
  // (With FillOptions::crease_split_retries = 0 the whole-hole methods fill it, 54.6‰ off: not
  // repeated here, its faired 3D triangulation takes two minutes under the sanitizers.)
}

// Five balls cut out of fandisk (touchmend-cut-bench --only fandisk.obj:1:9) leave a 68-edge
// hole with eight crease crossings. One of its creases runs within a mean edge of the rim, and
// the strip between them folds: every split along it crosses the mesh. The curve left out is
// the one nearest the crossing, so the split along the others is made (20°, 1.4‰ of the
// diagonal from the removed faces); taking out the least certain pairs instead kept the
// troublesome one to the end, and the hole went to the 3D triangulation (2.0°, 7.3‰). Since two
// creases left over may meet at a corner of their own (2026-11-27) the plan has five curves,
// and the split along four of them is 0.44‰ off, 17.1°.
TEST(FillHole, ACreaseSplitRetryLeavesOutTheCurveNearestWhereItCrossedTheMesh) {
  const std::array<std::pair<Vec3, double>, 5> balls{
      {{Vec3(0.651222, 15.0116, -2.64694), 1.0961208},
       {Vec3(4.8279, 13.7969, -0.274985), 0.347678572},
       {Vec3(3.74789, 16.9988, 0), 0.924380962},
       {Vec3(1.63317, 16.0422, 0), 0.922556583},
       {Vec3(2.74898, 15.3371, -1.73575), 0.739925778}}};
  std::vector<TrianglePoints> truth;
  const MeshSoup cut = cut_shared_mesh("fandisk.obj", balls, &truth);
  const auto hole_175 = [](const Hole& h) { return h.id == 175 && h.loop.size() == 68; };
  const FillRun run = fill_and_check(cut, {}, hole_175);
  ASSERT_NO_FATAL_FAILURE(expect_split_along_fewer_curves(run, 4, 5));
  const HoleFillReport& r = run.reports[0];
  EXPECT_GE(r.min_angle_deg, 15.0);
  const double diagonal = 7.6156;  // fandisk's bounding-box diagonal (rounded)
  EXPECT_LT(mean_distance_to(run, r, truth, diagonal), 0.001);
}

TEST(FillHole, HoleAcrossACubeEdgeFollowsTheCrease) {
  const MeshSoup s = testing::cube_with_hole(8, Vec3(8, 4, 8), 2.2);
  FillOptions plain;  // without crease retaining: the auto shape alone
  plain.sharp = SharpMode::Off;
  const FillRun run = fill_and_check(s, plain, [](const Hole&) { return true; });
  ASSERT_EQ(run.reports.size(), 1u);
  const HoleFillReport& r = run.reports[0];
  ASSERT_TRUE(r.filled) << r.reason;
  EXPECT_EQ(r.shape, PatchShape::Flat) << r.shape_reason;
  EXPECT_NE(r.shape_reason.find("sharp edges"), std::string::npos) << r.shape_reason;
  // Every new vertex lies inside the cube, no farther than a cell from its true surface (the
  // graded refinement may split a chord across the edge at its midpoint, which lies a cell in).
  for (const auto v : r.new_vertices) {
    const Vec3 p = run.mesh.point(v);
    for (int k = 0; k < 3; ++k) {
      EXPECT_GE(p[k], -1e-9);
      EXPECT_LE(p[k], 8 + 1e-9);
    }
    EXPECT_LE(std::min(8 - p[0], 8 - p[2]), 1.0 + 1e-9);
  }
  EXPECT_GE(r.min_angle_deg, 15.0);
}

TEST(FillHole, DefaultFillKeepsTheCubeEdgeThroughTheHole) {
  // Crease retaining is on by default: the two ends of the edge x = z = 8 that cross the hole
  // are paired and the hole is filled split along the edge, so the edge is in the patch.
  const MeshSoup s = testing::cube_with_hole(8, Vec3(8, 4, 8), 2.2);
  const FillRun run = fill_and_check(s, {}, [](const Hole&) { return true; });
  ASSERT_EQ(run.reports.size(), 1u);
  const HoleFillReport& r = run.reports[0];
  ASSERT_TRUE(r.filled) << r.reason;
  EXPECT_EQ(r.method, FillMethod::CreaseSplit) << r.creases;
  EXPECT_EQ(r.crease_curves, 1u);
  const std::array<std::array<Vec3, 2>, 1> edge{{{Vec3(8, 2.2, 8), Vec3(8, 5.8, 8)}}};
  EXPECT_LT(segment_distance(edge, face_triangles(run.mesh, r.new_faces), 0.01).max, 1e-9);
}

TEST(FillHole, HoleWrapping270DegreesAroundACylinderGoesPiecewise) {
  const MeshSoup s = remove_faces(testing::cylinder(1.0, 4.0, 64, 33), [](const Vec3& c) {
    const double a = std::atan2(c[1], c[0]);
    return std::abs(a) < 0.75 * std::numbers::pi && c[2] > 1.6 && c[2] < 2.4;
  });
  FillRun run{build_mesh(s).mesh, {}, {}};
  run.holes = find_holes(run.mesh).holes;
  const Hole* wrap = nullptr;
  for (const auto& h : run.holes)
    if (h.loop.size() != 64) wrap = &h;
  ASSERT_NE(wrap, nullptr);
  EXPECT_FALSE(wrap->is_simple) << "a 270° window cannot project onto any plane";
  const testing::Snapshot before = take_snapshot(run.mesh);
  run.reports.push_back(fill_hole(run.mesh, *wrap, {}));
  const HoleFillReport& r = run.reports[0];
  ASSERT_TRUE(r.filled) << r.reason;
  EXPECT_EQ(r.method, FillMethod::Piecewise);
  EXPECT_GT(r.pieces, 1u);
  const std::string problems = check_fill_invariants(before, run.mesh, run.reports, run.holes);
  EXPECT_TRUE(problems.empty()) << problems;
  double worst = 0;
  for (const auto v : r.new_vertices) {
    const Vec3 p = run.mesh.point(v);
    worst = std::max(worst, std::abs(std::hypot(p[0], p[1]) - 1.0));
  }
  EXPECT_LT(worst, 0.1);
}

TEST(FillHole, SaddleHoleProjectsAndGoesPlanar) {
  auto saddle = [](double x, double y) { return 0.04 * ((x - 8) * (x - 8) - (y - 8) * (y - 8)); };
  const MeshSoup s = testing::grid_with_round_hole(saddle);
  const FillRun run = fill_and_check(s, {}, [](const Hole& h) { return h.loop.size() < 64; });
  ASSERT_EQ(run.reports.size(), 1u);
  const HoleFillReport& r = run.reports[0];
  ASSERT_TRUE(r.filled) << r.reason;
  EXPECT_EQ(r.method, FillMethod::Planar);
  EXPECT_EQ(r.shape, PatchShape::Fair);
  for (const auto v : r.new_vertices) {
    const Vec3 p = run.mesh.point(v);
    EXPECT_NEAR(p[2], saddle(p[0], p[1]), 0.05);
  }
  EXPECT_GE(min_new_angle(run), 15.0);
}

TEST(FillHole, TwoHolesSharingAVertexAreFilledOneAtATime) {
  const MeshSoup s = remove_faces(testing::grid(8, 8), [](const Vec3& c) {
    return (c[0] > 2 && c[0] < 4 && c[1] > 2 && c[1] < 4) ||
           (c[0] > 4 && c[0] < 6 && c[1] > 4 && c[1] < 6);
  });
  Mesh mesh = build_mesh(s).mesh;
  auto holes = find_holes(mesh).holes;
  std::vector<const Hole*> inner;
  for (const auto& h : holes)
    if (h.loop.size() == 8) inner.push_back(&h);
  ASSERT_EQ(inner.size(), 2u);
  const std::uint32_t second_id = inner[1]->id;
  const testing::Snapshot before = take_snapshot(mesh);
  const HoleFillReport first = fill_hole(mesh, *inner[0], {});
  ASSERT_TRUE(first.filled) << first.reason;
  EXPECT_TRUE(check_fill_invariants(before, mesh, {first}, holes).empty());
  // The other hole is untouched and keeps its id.
  const auto after = find_holes(mesh).holes;
  const auto again = find_hole_by_id(after, second_id);
  ASSERT_TRUE(again);
  EXPECT_EQ(after[*again].loop.size(), 8u);
  const HoleFillReport second = fill_hole(mesh, after[*again], {});
  ASSERT_TRUE(second.filled) << second.reason;
  EXPECT_EQ(find_holes(mesh).holes.size(), 1u);  // only the outer border is left
  EXPECT_EQ(validate_mesh(mesh).non_manifold_vertices, 0u);
  EXPECT_TRUE(find_face_intersections(mesh, second.new_faces).empty());
}

FillRun fill_pinched(const MeshSoup& soup) {
  FillRun run = fill_and_check(soup, {}, [](const Hole& h) { return !h.pinched_at.empty(); });
  EXPECT_EQ(run.reports.size(), 1u);
  return run;
}

// A hole whose loop passes a vertex twice bounds the gap between an island and the surface it
// touches there. One triangle across a corner of the pinch makes it a disk, which is filled;
// the result is closed and manifold at the pinch.
TEST(FillHole, HolePinchedByAnIslandIsClosedAcrossThePinch) {
  const FillRun run =
      fill_pinched(testing::cut_leaving_an_island(testing::grid(12, 12), {6, 6, 0}, 3.2));
  ASSERT_EQ(run.reports.size(), 1u);
  const HoleFillReport& r = run.reports[0];
  ASSERT_TRUE(r.filled) << r.reason;
  ASSERT_FALSE(r.warnings.empty());
  EXPECT_NE(r.warnings[0].find("pinched"), std::string::npos) << r.warnings[0];
  EXPECT_EQ(find_holes(run.mesh).holes.size(), 1u);  // only the grid's border is left
  EXPECT_EQ(validate_mesh(run.mesh).non_manifold_vertices, 0u);
  EXPECT_TRUE(find_face_intersections(run.mesh, r.new_faces).empty());
  for (const VertexHandle v : run.mesh.vertices()) EXPECT_EQ(run.mesh.point(v)[2], 0.0);
  EXPECT_GE(min_new_angle(run), 15.0);
}

TEST(FillHole, PinchedHoleOnASphereIsFairedBackOntoIt) {
  const FillRun run = fill_pinched(
      testing::cut_leaving_an_island(testing::uv_sphere(1, 48, 24), {0, 0.6, 0.8}, 0.45));
  ASSERT_EQ(run.reports.size(), 1u);
  const HoleFillReport& r = run.reports[0];
  ASSERT_TRUE(r.filled) << r.reason;
  EXPECT_EQ(r.shape, PatchShape::Fair) << r.shape_reason;
  EXPECT_TRUE(find_holes(run.mesh).holes.empty());
  EXPECT_EQ(validate_mesh(run.mesh).non_manifold_vertices, 0u);
  EXPECT_TRUE(find_face_intersections(run.mesh, r.new_faces).empty());
  for (const VertexHandle v : r.new_vertices) EXPECT_NEAR(run.mesh.point(v).norm(), 1.0, 0.02);
}

// A comb of lone teeth on a cylinder wall that touch at their lower corners (a loop through
// every shared corner twice; testing::comb_cut_cylinder): filled, closed and manifold,
// and the pinches closed along the wall, so that every new face faces away from the axis (a
// chord across the ring under the teeth would face along it) and none leaves the cylinder by
// more than a flat patch's sag over the cut's sector.
TEST(FillHole, ACombOfTeethOnACylinderWallIsFilledAlongTheWall) {
  const FillRun run = fill_and_check(testing::comb_cut_cylinder(testing::CombTeeth::Lone), {},
                                     [](const Hole& h) { return h.pinched_at.size() >= 4; });
  ASSERT_EQ(run.reports.size(), 1u);
  const HoleFillReport& r = run.reports[0];
  ASSERT_TRUE(r.filled) << r.reason;
  EXPECT_EQ(find_holes(run.mesh).holes.size(), 2u);  // the cylinder's two open ends
  EXPECT_EQ(validate_mesh(run.mesh).non_manifold_vertices, 0u);
  EXPECT_TRUE(find_face_intersections(run.mesh, r.new_faces).empty());
  // The sector spans 1 radian: a chord across it sags 0.05 (1 - cos 0.5) = 0.006 inside.
  for (const FaceHandle f : r.new_faces) {
    const Vec3 c = run.mesh.calc_face_centroid(f);
    EXPECT_NEAR(std::hypot(c[0], c[1]), 0.05, 0.0065) << "face " << f.idx();
    EXPECT_LT(std::abs(run.mesh.calc_face_normal(f)[2]), 0.5) << "face " << f.idx();
  }
}

// The outside of a flat bowtie: one triangle closes the pinch, but every patch of the four-edge
// loop left would lie on the bowtie's own triangles. The hole stays open, says why, and the
// triangle across the pinch is taken out again: the mesh is as it was.
TEST(FillHole, PinchThatNoTriangleCanCloseLeavesTheMeshAsItWas) {
  MeshSoup s;
  s.points = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {-1, 0, 0}, {-1, -1, 0}};
  s.triangles = {{0, 1, 2}, {0, 3, 4}};
  FillRun run = fill_and_check(s, {}, [](const Hole&) { return true; });
  ASSERT_EQ(run.reports.size(), 1u);
  const HoleFillReport& r = run.reports[0];
  EXPECT_FALSE(r.filled);
  EXPECT_NE(r.reason.find("pinched"), std::string::npos) << r.reason;
  run.mesh.garbage_collection();
  EXPECT_EQ(run.mesh.n_faces(), 2u);
  EXPECT_EQ(run.mesh.n_edges(), 6u);
}

// A cut that leaves a lone triangle: its outline is a three-edge loop, whose only patch would be
// the triangle's back. It stays open, and the reason says the loop borders a fragment.
TEST(FillHole, OutlineOfALoneTriangleSaysItBordersAFragment) {
  MeshSoup s = testing::grid_with_round_hole();
  const auto base = static_cast<std::uint32_t>(s.points.size());
  s.points.push_back({7.6, 7.7, 0.2});
  s.points.push_back({8.4, 7.8, 0.2});
  s.points.push_back({8.0, 8.4, 0.2});
  s.triangles.push_back({base, base + 1, base + 2});
  const FillRun run = fill_and_check(s, {}, [](const Hole& h) { return h.loop.size() < 60; });
  std::size_t fragments = 0, filled = 0;
  for (const HoleFillReport& r : run.reports) {
    if (r.filled) ++filled;
    if (r.boundary_vertices != 3) continue;
    EXPECT_FALSE(r.filled);
    EXPECT_NE(r.reason.find("separate piece of 1 face (a fragment"), std::string::npos) << r.reason;
    ++fragments;
  }
  EXPECT_EQ(fragments, 1u);
  EXPECT_EQ(filled, 1u);  // the round hole around it is filled
}

// Asked to, the fill deletes the lone triangle whose outline it cannot fill, with its three
// vertices; the round hole around it is filled as before and nothing else changes.
TEST(FillHole, RemovingFragmentsDeletesTheLoneTriangleInstead) {
  const MeshSoup s = testing::with_lone_triangle(testing::grid_with_round_hole(), {7.6, 7.7, 0.2});
  FillOptions options;
  options.remove_fragments = true;
  const FillRun run = fill_and_check(s, options, [](const Hole& h) { return h.loop.size() < 60; });
  ASSERT_EQ(run.reports.size(), 2u);
  std::size_t removed = 0, filled = 0, new_faces = 0;
  for (const HoleFillReport& r : run.reports) {
    new_faces += r.new_faces.size();
    if (r.filled) ++filled;
    if (!r.fragment_removed()) continue;
    ++removed;
    EXPECT_FALSE(r.filled);
    EXPECT_EQ(r.boundary_vertices, 3u);
    EXPECT_EQ(r.removed_faces.size(), 1u);
    EXPECT_EQ(r.removed_vertices.size(), 3u);
    for (const VertexHandle v : r.removed_vertices) EXPECT_TRUE(run.mesh.status(v).deleted());
    EXPECT_NE(r.reason.find("deleted the separate piece of 1 face"), std::string::npos) << r.reason;
  }
  EXPECT_EQ(removed, 1u);
  EXPECT_EQ(filled, 1u);
  Mesh after = run.mesh;
  after.garbage_collection();
  EXPECT_EQ(after.n_faces(), s.triangles.size() - 1 + new_faces);
  EXPECT_EQ(after.n_vertices(), s.points.size() - 3 + run.reports[0].new_vertices.size() +
                                    run.reports[1].new_vertices.size());
  EXPECT_EQ(find_holes(after).holes.size(), 1u);  // the grid's own border
}

// Without the option the fragment stays (the input's data), and a larger piece is no fragment:
// a loop around more faces than it has edges is left to the fill.
TEST(FillHole, FragmentsAreRemovedOnlyWhenAskedAndOnlySmallOnes) {
  const MeshSoup debris = testing::with_lone_triangle(testing::grid(4, 4), {10, 0, 0});
  Mesh mesh = build_mesh(debris).mesh;
  FillSelection all;
  FillReport report = fill_holes(mesh, all, FillOptions{});
  EXPECT_EQ(report.fragments_removed(), 0u);
  EXPECT_EQ(report.left_open(), 2u);  // the triangle's outline and the grid's border
  mesh.garbage_collection();
  EXPECT_EQ(mesh.n_faces(), debris.triangles.size());
  FillOptions remove;
  remove.remove_fragments = true;
  report = fill_holes(mesh, all, remove);
  EXPECT_EQ(report.fragments_removed(), 1u);
  EXPECT_EQ(report.left_open(), 1u);  // a grid of 32 faces is no fragment of its 16-edge border
  mesh.garbage_collection();
  EXPECT_EQ(mesh.n_faces(), debris.triangles.size() - 1);
  EXPECT_EQ(mesh.n_vertices(), debris.points.size() - 3);
}

// A cut that takes the plate's second ring round a counterbore's mouth leaves the first ring as
// an island, held only by the counterbore's wall (couplingdown's ball cuts s2c9 and s12c1 leave
// such rings round its bores). Its outer border, filled alone, stays open: every patch over it
// would lie on the island, and the reason says the faces along the loop lie inside it. The
// plate's inner border, also planar and left open alone (its patch would cover the island), has
// its faces outside it: no such note.
TEST(FillHole, AnIslandsBorderIsLeftOpenWithTheFacesInsideItNamed) {
  constexpr int kAround = 24;
  constexpr double kRadius = 2.0, kDepth = 0.5, kBoreRadius = 1.0, kBoreDepth = 2.0;
  const MeshSoup soup = testing::remove_faces(
      testing::plate_with_a_counterbore(kAround, kRadius, kDepth, kBoreRadius, kBoreDepth),
      [&](const Vec3& c) {
        const double r = std::hypot(c[0], c[1]);
        return std::abs(c[2]) < 1e-9 && r > kRadius + 1 && r < kRadius + 2;
      });
  const Mesh original = build_mesh(soup).mesh;
  const auto hole_at = [&](double radius) -> std::uint32_t {
    for (const Hole& h : find_holes(original).holes) {
      double mean = 0;
      for (const VertexHandle v : h.loop)
        mean += std::hypot(original.point(v)[0], original.point(v)[1]);
      if (std::abs(mean / static_cast<double>(h.loop.size()) - radius) < 0.05) return h.id;
    }
    ADD_FAILURE() << "no loop at radius " << radius;
    return 0;
  };
  const auto fill_alone = [&](std::uint32_t id) {
    Mesh mesh = original;
    FillSelection one;
    one.mode = FillSelection::Mode::Ids;
    one.ids = {id};
    const FillReport report = fill_holes(mesh, one, FillOptions{});
    EXPECT_EQ(report.holes.size(), 1u);
    return report.holes.empty() ? HoleFillReport{} : report.holes[0];
  };
  constexpr std::string_view kNote = "of the faces along the loop lie inside its outline";
  const HoleFillReport island = fill_alone(hole_at(kRadius + 1));
  EXPECT_FALSE(island.filled);
  EXPECT_NE(island.reason.find(fmt::format("{} {}", kAround, kNote)), std::string::npos)
      << island.reason;
  const HoleFillReport plate = fill_alone(hole_at(kRadius + 2));
  EXPECT_FALSE(plate.filled);
  EXPECT_EQ(plate.reason.find(kNote), std::string::npos) << plate.reason;
}

TEST(FillHole, ThreeEdgeHoleGetsOneTriangle) {
  MeshSoup s = testing::cube(2);
  s.triangles.erase(s.triangles.begin() + 5);
  const FillRun run = fill_and_check(s, {}, [](const Hole&) { return true; });
  ASSERT_EQ(run.reports.size(), 1u);
  EXPECT_TRUE(run.reports[0].filled);
  EXPECT_EQ(run.reports[0].faces_added, 1u);
  EXPECT_EQ(run.reports[0].vertices_added, 0u);
  EXPECT_TRUE(find_holes(run.mesh).holes.empty());
}

// On a curved surface the auto shape asks for fairing, but a one-triangle patch has no vertex to
// move: the report says it is flat, and why.
TEST(FillHole, AThreeEdgeHoleOnASphereIsReportedAsTheRimsTriangleNotAFairedPatch) {
  MeshSoup s = testing::uv_sphere(1.0, 24, 12);
  s.triangles.erase(s.triangles.begin() + static_cast<std::ptrdiff_t>(s.triangles.size() / 2));
  const FillRun run = fill_and_check(s, {}, [](const Hole& h) { return h.loop.size() == 3; });
  ASSERT_EQ(run.reports.size(), 1u);
  const HoleFillReport& r = run.reports[0];
  ASSERT_TRUE(r.filled) << r.reason;
  EXPECT_EQ(r.faces_added, 1u);
  EXPECT_EQ(r.vertices_added, 0u);
  EXPECT_EQ(r.shape, PatchShape::Flat) << r.shape_reason;
  EXPECT_NE(r.shape_reason.find("no vertex inside the patch"), std::string::npos) << r.shape_reason;
}

// A three-edge hole whose corners are all but collinear (one moved to a millionth of the
// hole's size off the opposite edge): its one possible triangle is degenerate. Every method is
// refused for it, and the first is then repeated and kept: a closed hole with a sliver is more
// use than an open one (hole_filling.cpp, the degenerate-triangle rule).
TEST(FillHole, ThreeEdgeHoleWithNearlyCollinearCornersIsStillClosed) {
  MeshSoup s = testing::grid(4, 4);
  const std::size_t removed = 10;  // an interior triangle
  const auto corners = s.triangles[removed];
  s.triangles.erase(s.triangles.begin() + static_cast<std::ptrdiff_t>(removed));
  const Vec3 a = s.points[corners[0]], b = s.points[corners[1]];
  Vec3& c = s.points[corners[2]];
  const Vec3 middle = 0.5 * (a + b);
  c = middle + 1e-6 * (c - middle);
  Mesh mesh = build_mesh(s).mesh;
  std::vector<Hole> holes;
  for (const Hole& h : find_holes(mesh).holes)
    if (h.loop.size() == 3) holes.push_back(h);
  ASSERT_EQ(holes.size(), 1u);
  const HoleFillReport r = fill_hole(mesh, holes[0], {});
  ASSERT_TRUE(r.filled) << r.reason;
  EXPECT_EQ(r.faces_added, 1u);
  EXPECT_LT(r.min_angle_deg, 0.1);
  bool said = false;
  for (const auto& w : r.warnings)
    said = said || w.find("without a degenerate triangle: kept the first") != std::string::npos;
  EXPECT_TRUE(said);
  const ValidationReport v = validate_mesh(mesh);
  EXPECT_EQ(v.non_manifold_edges, 0u);
  EXPECT_EQ(v.inconsistent_edges, 0u);
}

TEST(FillHole, ThousandVertexHole) {
  const MeshSoup s = testing::annulus(1000, 100.0, 3, 0.7);
  const FillRun run = fill_and_check(s, {}, [](const Hole& h) {
    return h.loop.size() == 1000 && h.perimeter < 630; /* the inner circle, not the border */
  });
  ASSERT_EQ(run.reports.size(), 1u);
  const HoleFillReport& r = run.reports[0];
  ASSERT_TRUE(r.filled) << r.reason;
  EXPECT_EQ(r.method, FillMethod::Planar);
  EXPECT_EQ(r.boundary_vertices, 1000u);
  for (const auto v : r.new_vertices) EXPECT_EQ(run.mesh.point(v)[2], 0.0);
  EXPECT_GE(min_new_angle(run), 15.0);
}

TEST(FillHole, HoleThatCanOnlyIntersectIsLeftOpenAndNothingChanges) {
  // A grid with a hole and a separate triangle standing through the middle of the hole.
  MeshSoup s = remove_faces(testing::grid(10, 10), [](const Vec3& c) {
    return c[0] > 3 && c[0] < 7 && c[1] > 3 && c[1] < 7;
  });
  const auto base = static_cast<std::uint32_t>(s.points.size());
  s.points.push_back({3.2, 5, -1});
  s.points.push_back({6.8, 5, -1});
  s.points.push_back({5, 5, 2});
  s.triangles.push_back({base, base + 1, base + 2});
  Mesh mesh = build_mesh(s).mesh;
  const auto holes = find_holes(mesh).holes;
  const Hole* hole = nullptr;
  for (const auto& h : holes)
    if (h.loop.size() == 16) hole = &h;
  ASSERT_NE(hole, nullptr);
  const testing::Snapshot before = take_snapshot(mesh);
  const std::size_t faces_before = mesh.n_faces();
  const HoleFillReport r = fill_hole(mesh, *hole, {});
  EXPECT_FALSE(r.filled);
  EXPECT_NE(r.reason.find("intersect"), std::string::npos) << r.reason;
  EXPECT_EQ(r.reason.find("fragment"), std::string::npos) << r.reason;  // a hole in the grid
  mesh.garbage_collection();
  EXPECT_EQ(mesh.n_faces(), faces_before);
  EXPECT_EQ(testing::boundary_halfedges(mesh), before.boundary);
}

// A frayed border: a vertex one ring outside the rim pushed across it into the hole, so that
// its faces fold over their neighbours. Every patch meets the folded faces; the hole is left
// open and the reason says that the surface around it already intersects itself.
TEST(FillHole, HoleInAFoldedSurfaceSaysTheSurfaceIntersectsItself) {
  MeshSoup s = remove_faces(testing::grid(10, 10), [](const Vec3& c) {
    return c[0] > 3 && c[0] < 7 && c[1] > 3 && c[1] < 7;
  });
  bool moved = false;
  for (Vec3& p : s.points)
    if (p == Vec3(2, 5, 0)) {
      p = Vec3(4.5, 5, 0);  // past the rim vertex (3, 5)
      moved = true;
    }
  ASSERT_TRUE(moved);
  Mesh mesh = build_mesh(s).mesh;
  const Hole* hole = nullptr;
  const auto holes = find_holes(mesh).holes;
  for (const auto& h : holes)
    if (h.loop.size() == 16) hole = &h;
  ASSERT_NE(hole, nullptr);
  ASSERT_FALSE(find_self_intersections(mesh, 1).empty());
  const HoleFillReport r = fill_hole(mesh, *hole, {});
  EXPECT_FALSE(r.filled);
  EXPECT_NE(r.reason.find("the surface around the hole already intersects itself"),
            std::string::npos)
      << r.reason;
}

// Geometry a reader accepts but no scanner should produce: coordinates near the double range,
// denormal offsets, vertices collapsed onto others (zero-length edges, degenerate triangles),
// far translations that leave a few significant bits. Every hole is then either filled under
// every invariant or left open with a reason that names why, and no coordinate becomes
// non-finite (the sanitizer build runs this too).
TEST(FillRobustness, CorruptedGeometryIsFilledCleanlyOrLeftOpenWithAReason) {
  const MeshSoup clean = remove_faces(testing::uv_sphere(1.0, 24, 12), [](const Vec3& c) {
    return (c - Vec3(1, 0, 0)).norm() < 0.45 || (c - Vec3(0, 0, 1)).norm() < 0.35 ||
           (c - Vec3(-0.6, -0.6, -0.5)).norm() < 0.4;
  });
  std::mt19937 rng(2026);
  std::size_t filled = 0, left_open = 0;
  for (int trial = 0; trial < 40; ++trial) {
    MeshSoup soup = clean;
    const auto pick = [&] { return rng() % soup.points.size(); };
    switch (trial % 5) {
      case 0:  // a few vertices thrown to the edge of the double range
        for (int k = 0; k < 3; ++k)
          soup.points[pick()] = Vec3(1e300, -1e300, (rng() % 2 ? 1 : -1) * 1.7e308);
        break;
      case 1:  // vertices collapsed onto a neighbour's position
        for (int k = 0; k < 6; ++k) {
          const auto& t = soup.triangles[rng() % soup.triangles.size()];
          soup.points[t[0]] = soup.points[t[1]];
        }
        break;
      case 2:  // denormal-sized perturbations and a run of points collapsed into one
        for (int k = 0; k < 8; ++k) soup.points[pick()] += Vec3(4.9e-324, 0, -4.9e-324);
        for (std::size_t k = 0, first = pick(); k < 12; ++k)
          soup.points[(first + k) % soup.points.size()] = soup.points[first];
        break;
      case 3:  // the whole mesh far from the origin: 1e12 leaves ~4 digits of the unit sphere
        for (auto& p : soup.points) p += Vec3(1e12, -1e12, 1e12);
        break;
      case 4:  // the whole mesh scaled down to 1e-150 (squared lengths underflow)
        for (auto& p : soup.points) p *= 1e-150;
        break;
    }
    Mesh mesh = build_mesh(soup).mesh;
    const std::vector<Hole> holes = find_holes(mesh).holes;
    const testing::Snapshot before = take_snapshot(mesh);
    FillSelection all;
    all.mode = FillSelection::Mode::All;
    const FillReport report = fill_holes(mesh, all, {});
    for (const HoleFillReport& r : report.holes) {
      EXPECT_TRUE(r.filled || !r.reason.empty()) << "trial " << trial << " hole " << r.hole_id;
      (r.filled ? filled : left_open) += 1;
    }
    for (const VertexHandle v : mesh.vertices()) {
      const Vec3& p = mesh.point(v);
      ASSERT_TRUE(std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]))
          << "trial " << trial << " vertex " << v.idx();
    }
    const std::string problems = check_fill_invariants(before, mesh, report.holes, holes);
    EXPECT_TRUE(problems.empty()) << "trial " << trial << ": " << problems;
  }
  // Both outcomes occur: the corruptions are not all harmless, nor all fatal.
  EXPECT_GT(filled, 0u);
  EXPECT_GT(left_open, 0u);
}

// Scale alone decides whether the fill's products stay in the double range: the same hole at
// 1e-30 is filled, at 1e-150 or 1e100 it is refused with a reason that says to rescale (it was
// "filled" with 0-degree triangles, its normals having underflowed to zero).
TEST(FillRobustness, HoleAtAnExtremeScaleIsRefusedWithTheReason) {
  for (const double scale : {1e-30, 1e-150, 1e100}) {
    MeshSoup soup = testing::grid_with_round_hole();
    for (auto& p : soup.points) p *= scale;
    Mesh mesh = build_mesh(soup).mesh;
    const std::vector<Hole> holes = find_holes(mesh).holes;
    const Hole* inner = nullptr;
    for (const Hole& h : holes)
      if (h.loop.size() < 64) inner = &h;
    ASSERT_NE(inner, nullptr);
    const HoleFillReport r = fill_hole(mesh, *inner, {});
    if (scale == 1e-30) {
      EXPECT_TRUE(inner->unfillable_reason.empty()) << inner->unfillable_reason;
      ASSERT_TRUE(r.filled) << r.reason;
      EXPECT_GT(triangle_quality(face_triangles(mesh, r.new_faces)).min_angle_deg, 15.0);
    } else {
      EXPECT_NE(inner->unfillable_reason.find("rescale the mesh"), std::string::npos)
          << scale << ": " << inner->unfillable_reason;
      EXPECT_FALSE(r.filled);
      EXPECT_EQ(r.reason, inner->unfillable_reason);
    }
  }
}

TEST(FillHoles, SelectionByIdNearestAndSizeLimit) {
  const MeshSoup s = remove_faces(testing::grid(20, 8), [](const Vec3& c) {
    return (c[0] > 2 && c[0] < 5 && c[1] > 2 && c[1] < 5) ||
           (c[0] > 10 && c[0] < 16 && c[1] > 2 && c[1] < 6);
  });
  {
    Mesh m = build_mesh(s).mesh;
    FillSelection near;
    near.mode = FillSelection::Mode::Nearest;
    near.point = Vec3(3.5, 3.5, 0.3);
    const FillReport r = fill_holes(m, near);
    ASSERT_EQ(r.holes.size(), 1u);
    EXPECT_TRUE(r.holes[0].filled);
    EXPECT_EQ(r.holes[0].boundary_vertices, 12u);
  }
  {
    Mesh m = build_mesh(s).mesh;
    const auto holes = find_holes(m).holes;
    FillSelection ids;
    ids.mode = FillSelection::Mode::Ids;
    for (const auto& h : holes)
      if (h.loop.size() == 20) ids.ids.push_back(h.id);
    ids.ids.push_back(4242424);
    const FillReport r = fill_holes(m, ids);
    ASSERT_EQ(r.holes.size(), 1u);
    EXPECT_EQ(r.holes[0].boundary_vertices, 20u);
    EXPECT_EQ(r.unknown_ids, std::vector<std::uint32_t>{4242424});
  }
  {
    Mesh m = build_mesh(s).mesh;
    FillSelection all;
    all.max_boundary = 16;
    std::size_t progress_calls = 0;
    const FillReport r =
        fill_holes(m, all, {}, [&](std::size_t, std::size_t) { return ++progress_calls > 0; });
    EXPECT_EQ(r.holes_found, 3u);
    EXPECT_EQ(r.filled(), 1u);  // the 12-edge hole; the 20-edge hole and the border are skipped
    EXPECT_EQ(progress_calls, 3u);
    std::size_t skipped = 0;
    for (const auto& h : r.holes) skipped += h.skipped ? 1 : 0;
    EXPECT_EQ(skipped, 2u);
  }
}

TEST(FillHoles, MoreRefinementRoundsNeverMakeFewerTriangles) {
  const MeshSoup s = remove_faces(testing::grid(30, 30), [](const Vec3& c) {
    return (c[0] - 15) * (c[0] - 15) + (c[1] - 15) * (c[1] - 15) < 100;
  });
  std::size_t previous = 0;
  for (int rounds : {1, 3, 5}) {
    FillOptions o;
    o.refine_iterations = rounds;
    const FillRun run = fill_and_check(s, o, [](const Hole& h) { return h.loop.size() < 100; });
    ASSERT_TRUE(run.reports.at(0).filled);
    EXPECT_LE(run.reports[0].refinement_rounds, static_cast<std::size_t>(rounds));
    EXPECT_GE(run.reports[0].faces_added, previous);
    previous = run.reports[0].faces_added;
  }
}

TEST(PatchShape, ParsesAndPrints) {
  PatchShape s;
  EXPECT_TRUE(parse_patch_shape("fair", s));
  EXPECT_EQ(s, PatchShape::Fair);
  EXPECT_STREQ(to_string(s), "fair");
  EXPECT_FALSE(parse_patch_shape("round", s));
}

}  // namespace
}  // namespace touchmend::geometry
