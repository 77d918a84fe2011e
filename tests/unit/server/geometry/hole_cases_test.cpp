// Fills every hole of the shared cases (../shared/data/cases) and checks the result against the
// ground truth and the invariants. Bounds (per mille of the diagonal, anchors from BASELINE.md):
// every filled hole's mean distance to the removed surface within 1.6 x CGAL refine+fair's + 2,
// its Hausdorff distance within 2 x CGAL's + 5 — loose enough for the auto shape's choices
// (which beat CGAL on some holes and lose on others, see README), tight enough to catch a fill
// that bulges or misses the surface. Every hole closes: the two whose minimum-weight
// triangulations all cross the surrounding surface (couplingdown_sharp #1, rocker-arm_xl #0;
// CGAL's fills of them intersect the mesh) are closed by the intersection-avoiding 3D
// triangulation and by ear clipping.

#include <array>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <numbers>
#include <optional>
#include <random>
#include <set>

#include <gtest/gtest.h>

#include "server/geometry/bvh.h"
#include "server/geometry/hole_filling.h"
#include "server/geometry/intersection.h"
#include "server/geometry/mesh_build.h"
#include "server/geometry/mesh_io.h"
#include "server/geometry/sharp_edges.h"
#include "server/geometry/sharpen.h"
#include "tests/support/cases.h"
#include "tests/support/invariants.h"
#include "tests/support/mesh_factory.h"

namespace touchmend::geometry {
namespace {

class HoleCases : public ::testing::TestWithParam<std::string> {};

TEST_P(HoleCases, FillsCloseToGroundTruthWithoutBreakingTheMesh) {
  std::string error;
  const auto c = testing::load_case(GetParam(), error);
  ASSERT_TRUE(c) << error;
  const auto baseline = testing::read_baseline();
  Mesh mesh = build_mesh(c->holed).mesh;
  const auto holes = find_holes(mesh).holes;
  const testing::Snapshot before = testing::take_snapshot(mesh);
  const FillReport report = fill_holes(mesh, {});
  EXPECT_EQ(report.holes.size(), holes.size());
  const std::string problems = testing::check_fill_invariants(before, mesh, report.holes, holes);
  EXPECT_TRUE(problems.empty()) << problems;
  if (c->holes.empty()) {  // real scan holes, no ground truth: all must close
    for (const auto& r : report.holes)
      EXPECT_TRUE(r.filled) << "hole " << r.hole_id << ": " << r.reason;
    return;
  }
  ASSERT_EQ(holes.size(), c->holes.size());
  for (const auto& ch : c->holes) {
    const auto id = testing::matching_hole_id(holes, ch);
    ASSERT_TRUE(id) << "case hole " << ch.id << " not found";
    const HoleFillReport* r = nullptr;
    for (const auto& h : report.holes)
      if (h.hole_id == *id) r = &h;
    ASSERT_NE(r, nullptr);
    const std::pair<std::string, std::string> key{c->name, std::to_string(ch.id)};
    ASSERT_TRUE(r->filled) << "hole " << ch.id << " left open: " << r->reason;
    const testing::HoleScore score = testing::score_fill(mesh, *r, *c, ch);
    const auto anchor = baseline.find(key);
    ASSERT_NE(anchor, baseline.end())
        << "BASELINE.md has no row for " << c->name << " hole " << ch.id;
    EXPECT_LE(score.mean_permille, 1.6 * anchor->second.cgal_fair_mean + 2.0)
        << c->name << " hole " << ch.id << " (" << to_string(r->method) << ", "
        << to_string(r->shape) << ")";
    EXPECT_LE(score.hausdorff_permille, 2.0 * anchor->second.cgal_fair_hausdorff + 5.0)
        << c->name << " hole " << ch.id << " (" << to_string(r->method) << ", "
        << to_string(r->shape) << ")";
  }
}

INSTANTIATE_TEST_SUITE_P(SharedData, HoleCases, ::testing::ValuesIn(testing::list_cases()),
                         [](const auto& param_info) {
                           std::string name = param_info.param;
                           for (char& ch : name)
                             if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
                           return name;
                         });

// Sharp-edge retaining without a device (`SharpMode::Auto`) on the *_sharp cases, against the
// plain fill of the same holes. Everywhere: the invariants hold and the ground-truth creases
// are no farther from the patch than with the plain fill. Where the hole was split along crease
// curves: the patch is also closer to the ground truth (Hausdorff and mean) and the crease
// distance is at most 3 per mille of the diagonal, except on the holes listed below, where
// detection finds no clean crease (README "Sharp edges" says why).
const std::set<std::pair<std::string, std::string>> kCreaseNotRecovered = {
    {"couplingdown_sharp", "1"},  // three rings joined by arcs; a fourth enters along the rim
    {"couplingdown_sharp", "2"},  // two parallel creases 0.025 apart and a bend: no corner
    {"rocker-arm_sharp", "0"}};   // a jagged scan crease that fades to 40 deg at the boundary

class SharpCases : public ::testing::TestWithParam<std::string> {};

TEST_P(SharpCases, RetainedCreasesAreCloserToGroundTruth) {
  std::string error;
  const auto c = testing::load_case(GetParam(), error);
  ASSERT_TRUE(c) << error;
  Mesh plain_mesh = build_mesh(c->holed).mesh;
  Mesh sharp_mesh = build_mesh(c->holed).mesh;
  const auto holes = find_holes(sharp_mesh).holes;
  const testing::Snapshot before = testing::take_snapshot(sharp_mesh);
  FillOptions plain_options;
  plain_options.sharp = SharpMode::Off;
  const FillReport plain = fill_holes(plain_mesh, {}, plain_options);
  FillOptions options;
  options.sharp = SharpMode::Auto;
  const FillReport sharp = fill_holes(sharp_mesh, {}, options);
  const std::string problems =
      testing::check_fill_invariants(before, sharp_mesh, sharp.holes, holes);
  EXPECT_TRUE(problems.empty()) << problems;
  std::size_t split = 0;
  for (const auto& ch : c->holes) {
    const auto id = testing::matching_hole_id(holes, ch);
    ASSERT_TRUE(id);
    const HoleFillReport* p = nullptr;
    const HoleFillReport* r = nullptr;
    for (const auto& h : plain.holes) p = h.hole_id == *id ? &h : p;
    for (const auto& h : sharp.holes) r = h.hole_id == *id ? &h : r;
    ASSERT_TRUE(p && r);
    const std::pair<std::string, std::string> key{c->name, std::to_string(ch.id)};
    ASSERT_TRUE(r->filled) << "hole " << ch.id << " left open: " << r->reason;
    ASSERT_TRUE(p->filled) << "hole " << ch.id << " left open: " << p->reason;
    const auto s_plain = testing::score_fill(plain_mesh, *p, *c, ch);
    const auto s_sharp = testing::score_fill(sharp_mesh, *r, *c, ch);
    const std::string where = c->name + " hole " + std::to_string(ch.id) + " (" + r->creases + ")";
    EXPECT_LE(s_sharp.crease_permille, s_plain.crease_permille + 0.01) << where;
    if (r->method != FillMethod::CreaseSplit) continue;
    ++split;
    if (kCreaseNotRecovered.count(key)) continue;
    EXPECT_LE(s_sharp.crease_permille, 3.0) << where;
    EXPECT_LT(s_sharp.hausdorff_permille, s_plain.hausdorff_permille) << where;
    EXPECT_LT(s_sharp.mean_permille, s_plain.mean_permille) << where;
  }
  if (c->name == "fandisk_sharp") {
    EXPECT_EQ(split, 3u);  // every hole's creases found
  }
}

//! Fills case hole \p case_hole of \p c by sharpen_hole from picks an operator would make on
//! the first crease pair the detection finds: P2, P3 where the creases meet the rim, P1, P4 on
//! the creases, moved sideways (across the crease, in the hole's plane) by \p offset mean
//! boundary edges. Scores the patch; the invariants must hold.
struct PickedScore {
  SharpenResult result;
  testing::HoleScore score;
};
//! The hole of \p holes that case hole \p case_hole of \p c left (a test failure if none).
const Hole* case_hole_in(const std::vector<Hole>& holes, const testing::HoleCase& c,
                         std::size_t case_hole) {
  const auto id = testing::matching_hole_id(holes, c.holes.at(case_hole));
  EXPECT_TRUE(id) << c.name << " hole " << case_hole << " is not among the mesh's holes";
  return id ? &holes[*find_hole_by_id(holes, *id)] : nullptr;
}

//! A case with its holed mesh built, its holes found and the one case hole \p case_hole left:
//! where the single-hole tests start.
struct CaseMesh {
  testing::HoleCase c;
  Mesh mesh;
  std::vector<Hole> holes;
  const Hole* hole = nullptr;
};
std::unique_ptr<CaseMesh> load_case_mesh(const std::string& name, std::size_t case_hole) {
  std::string error;
  auto c = testing::load_case(name, error);
  if (!c) {
    ADD_FAILURE() << error;
    return nullptr;
  }
  auto loaded = std::make_unique<CaseMesh>();
  loaded->c = std::move(*c);
  loaded->mesh = build_mesh(loaded->c.holed).mesh;
  loaded->holes = find_holes(loaded->mesh).holes;
  loaded->hole = case_hole_in(loaded->holes, loaded->c, case_hole);
  if (!loaded->hole) return nullptr;
  return loaded;
}

//! Case hole \p case_hole of \p c filled alone without crease retaining (the fill the picks
//! must beat), scored; none if it could not be filled.
std::optional<testing::HoleScore> plain_fill_score(const testing::HoleCase& c,
                                                   std::size_t case_hole) {
  Mesh mesh = build_mesh(c.holed).mesh;
  const auto holes = find_holes(mesh).holes;
  const Hole* hole = case_hole_in(holes, c, case_hole);
  if (!hole) return std::nullopt;
  FillOptions plain;
  plain.sharp = SharpMode::Off;
  const HoleFillReport p = fill_hole(mesh, *hole, plain);
  EXPECT_TRUE(p.filled) << p.reason;
  if (!p.filled) return std::nullopt;
  return testing::score_fill(mesh, p, c, c.holes.at(case_hole));
}

//! Which of the detected creases the operator picks: the first pair (the thesis' four points),
//! or every crease the detection draws a curve on (pairs as P1..P4, a corner's creases as their
//! far and rim points).
enum class PickScope { FirstPair, EveryCrease };

PickedScore sharpen_picked(const testing::HoleCase& c, std::size_t case_hole,
                           const SharpenOptions& options, double offset = 0,
                           PickScope scope = PickScope::FirstPair,
                           const CreaseOptions& detection = {}) {
  Mesh mesh = build_mesh(c.holed).mesh;
  const auto holes = find_holes(mesh).holes;
  const Hole* found = case_hole_in(holes, c, case_hole);
  if (!found) return {};
  const Hole& hole = *found;
  const HoleCreasePlan plan = plan_hole_creases(mesh, hole, detection);
  const double shift = offset * hole.mean_edge_length;
  const auto on_crease = [&](const CreaseCrossing& x) {
    return x.on_crease + shift * OpenMesh::cross(x.inward, hole.normal).normalize_cond();
  };
  PickedCreases picked;
  for (const auto& curve : plan.curves) {
    const CreaseCrossing& from = plan.crossings[curve.from];
    if (curve.to) {
      const CreaseCrossing& to = plan.crossings[*curve.to];
      if (scope == PickScope::EveryCrease || picked.curves.empty())
        picked.curves.push_back({on_crease(from), from.position, to.position, on_crease(to)});
    } else if (scope == PickScope::EveryCrease) {
      picked.corner.push_back({on_crease(from), from.position});
    }
  }
  EXPECT_FALSE(picked.curves.empty() && picked.corner.empty()) << plan.summary;
  if (picked.curves.empty() && picked.corner.empty()) return {};
  const testing::Snapshot before = testing::take_snapshot(mesh);
  PickedScore out;
  out.result = scope == PickScope::FirstPair
                   ? sharpen_hole(mesh, hole, picked.curves.at(0), options)
                   : sharpen_creases(mesh, hole, picked, options);
  EXPECT_TRUE(out.result.ok) << out.result.failure;
  if (!out.result.ok) return out;
  HoleFillReport as_fill = out.result.fill;
  as_fill.new_faces = out.result.patch;
  const std::string problems = testing::check_fill_invariants(before, mesh, {as_fill}, holes);
  EXPECT_TRUE(problems.empty()) << problems;
  out.score = testing::score_sharpen(mesh, out.result, c, c.holes.at(case_hole));
  return out;
}

// Picked points on couplingdown_sharp's stepped bore (hole 1; the first crease pair the
// detection finds, picked on the creases): the push-down works, but the thesis' smoothing
// afterwards folds the patch into the mesh. The finish is undone and reported, and the pushed
// patch is kept (sharpen_picked checks every fill invariant), where the whole edit used to be
// refused.
TEST(SharpCasesPicked, FinishThatCrossesTheMeshIsUndoneAndThePushKept) {
  std::string error;
  const auto c = testing::load_case("couplingdown_sharp", error);
  ASSERT_TRUE(c) << error;
  SharpenOptions options;
  options.method = SharpenMethod::PushDown;
  options.finish = PushFinish::Smooth;
  // The pair a straight pairing finds (arcs off): the detection now joins this hole's creases,
  // rings, by circular arcs that no Hermite curve from four picks can follow.
  CreaseOptions straight_only;
  straight_only.arc_curvature_factor = 0;
  // And the pair found before pairs had to agree in dihedral angle (a 90° ring edge with a 45°
  // chamfer's), whose smoothing crosses the mesh.
  straight_only.max_pair_dihedral_ratio = 10.0;
  const PickedScore picked = sharpen_picked(*c, 1, options, 0, PickScope::FirstPair, straight_only);
  const SharpenResult& r = picked.result;
  ASSERT_TRUE(r.ok) << r.failure;
  EXPECT_GT(r.pushed, 0u);
  EXPECT_NE(r.finish.undone.find("intersect"), std::string::npos) << r.finish.undone;
  EXPECT_NE(push_down_summary(r, options.finish).find("smoothing undone"), std::string::npos);
}

// `--shape flat` on spot's curved holes: the spanning triangulation's folds follow no surface,
// so the mending flips across them, and every hole's smallest angle reaches DESIGN's 15°
// (measured: 16.0 -> 21.0, 2.7 -> 20.3, 4.2 -> 17.3°; before, only the first did). The patches
// stay where the flat fill puts them: mean distances 1.41, 7.14, 9.37‰ (1.37, 7.20, 9.98 before).
TEST(FlatShape, CurvedHolesAreMendedAcrossTheTriangulationsFolds) {
  std::string error;
  const auto c = testing::load_case("spot_sml", error);
  ASSERT_TRUE(c) << error;
  Mesh mesh = build_mesh(c->holed).mesh;
  const auto holes = find_holes(mesh).holes;
  const testing::Snapshot before = testing::take_snapshot(mesh);
  FillOptions options;
  options.shape = PatchShape::Flat;
  const FillReport report = fill_holes(mesh, {}, options);
  const std::string problems = testing::check_fill_invariants(before, mesh, report.holes, holes);
  EXPECT_TRUE(problems.empty()) << problems;
  ASSERT_EQ(c->holes.size(), 3u);
  const std::map<int, double> mean_bound{{0, 1.6}, {1, 7.5}, {2, 10.0}};
  for (const auto& ch : c->holes) {
    const auto id = testing::matching_hole_id(holes, ch);
    ASSERT_TRUE(id);
    const HoleFillReport* r = nullptr;
    for (const auto& h : report.holes) r = h.hole_id == *id ? &h : r;
    ASSERT_TRUE(r && r->filled) << "hole " << ch.id;
    EXPECT_EQ(r->shape, PatchShape::Flat);
    const auto score = testing::score_fill(mesh, *r, *c, ch);
    EXPECT_GE(score.quality.min_angle_deg, 15.0) << "hole " << ch.id;
    EXPECT_LE(score.mean_permille, mean_bound.at(ch.id)) << "hole " << ch.id;
  }
}

// Midpoint subdivision splits every triangle into coplanar ones, so spot subdivided twice is
// planar edge by edge (median dihedral 0) like a CAD part, and its 236-edge hole (59 on spot)
// meets two edges over 35°: it used to be filled flat along its 3D triangulation, with slivers.
// Its planes are spot's triangles, far smaller than the hole, and none reaches across it: the
// patch is faired, as on spot itself.
TEST(AutoShape, AFinelyFacetedCurvedSurfaceIsNotTakenForACadPart) {
  std::string error;
  const auto c = testing::load_case("spot_sml", error);
  ASSERT_TRUE(c) << error;
  const geometry::MeshSoup subdivided =
      testing::subdivide_midpoint(testing::subdivide_midpoint(c->holed));
  const testing::CaseHole* case_hole = nullptr;
  for (const auto& ch : c->holes)
    if (ch.loop_holed.size() == 59) case_hole = &ch;
  ASSERT_NE(case_hole, nullptr);
  const auto fill = [&](const FillOptions& options) {
    Mesh mesh = build_mesh(subdivided).mesh;
    const auto holes = find_holes(mesh).holes;
    const testing::Snapshot before = testing::take_snapshot(mesh);
    std::vector<HoleFillReport> reports;
    for (const Hole& h : holes)
      if (h.loop.size() == 4 * 59) reports.push_back(fill_hole(mesh, h, options));
    EXPECT_EQ(reports.size(), 1u);
    const std::string problems = testing::check_fill_invariants(before, mesh, reports, holes);
    EXPECT_TRUE(problems.empty()) << problems;
    if (reports.empty()) return std::make_pair(HoleFillReport{}, testing::HoleScore{});
    return std::make_pair(reports[0], testing::score_fill(mesh, reports[0], *c, *case_hole));
  };
  const auto [faired, faired_score] = fill({});
  ASSERT_TRUE(faired.filled) << faired.reason;
  EXPECT_EQ(faired.shape, PatchShape::Fair) << faired.shape_reason;
  EXPECT_NE(faired.shape_reason.find("finely faceted"), std::string::npos) << faired.shape_reason;
  EXPECT_GE(faired_score.quality.min_angle_deg, 15.0);

  FillOptions as_before;
  as_before.piecewise_planar_min_planes_across = 0;  // median dihedral alone
  const auto [flat, flat_score] = fill(as_before);
  ASSERT_TRUE(flat.filled) << flat.reason;
  EXPECT_EQ(flat.shape, PatchShape::Flat) << flat.shape_reason;
  EXPECT_LT(faired_score.mean_permille, flat_score.mean_permille);
  EXPECT_GT(faired_score.quality.min_angle_deg, flat_score.quality.min_angle_deg);
}

// Fandisk subdivided once is as planar edge by edge, but its faces continue across its holes
// (82% and 85% of the rim vertices lie on a plane that reaches across): they stay flat.
TEST(AutoShape, ASubdividedCadPartStaysPiecewisePlanar) {
  std::string error;
  const auto c = testing::load_case("fandisk_sml", error);
  ASSERT_TRUE(c) << error;
  Mesh mesh = build_mesh(testing::subdivide_midpoint(c->holed)).mesh;
  const auto holes = find_holes(mesh).holes;
  const FillReport report = fill_holes(mesh, {}, {});
  ASSERT_EQ(report.holes.size(), 3u);
  for (const HoleFillReport& r : report.holes) {
    ASSERT_TRUE(r.filled) << r.reason;
    EXPECT_EQ(r.shape, PatchShape::Flat) << r.hole_id << ": " << r.shape_reason;
    EXPECT_EQ(r.shape_reason.find("finely faceted"), std::string::npos) << r.shape_reason;
  }
}

// Picks no operator would make on spot's 23-edge hole (found by random picks): chord tangents
// with k of 3.6 and 4.6 put two curtain vertices at nearly the same place along the curve, and
// the push-down laid them 0.0003 apart, leaving a 0.03° needle. The result is refused with the
// reason, and the hole is left as it was.
TEST(SharpCasesPicked, PushThatLeavesADegenerateTriangleIsRefused) {
  std::string error;
  const auto c = testing::load_case("spot_sml", error);
  ASSERT_TRUE(c) << error;
  Mesh mesh = build_mesh(c->holed).mesh;
  const auto holes = find_holes(mesh).holes;
  const auto hole = find_hole_by_id(holes, 460);
  ASSERT_TRUE(hole);
  const auto boundary_before = testing::boundary_halfedges(mesh);
  const HermitePoints picks{{-0.45208836919784134, 0.040184056557543008, 0.13813112180961543},
                            {-0.36302299999999998, -0.091906199999999993, 0.052471700000000003},
                            {-0.14867452449806184, -0.28424753826304194, -0.11985934877262515},
                            {-0.029460200458264613, -0.35115599960020955, -0.18158597057732245}};
  SharpenOptions options;
  options.method = SharpenMethod::PushDown;
  options.tangents = PickTangents::Chord;
  options.finish = PushFinish::Fair;
  options.hermite.k1_scale = 3.5828221459140144;
  options.hermite.k4_scale = 4.5531460833211987;
  const SharpenResult r = sharpen_hole(mesh, holes[*hole], picks, options);
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.failure.find("degenerate triangle"), std::string::npos) << r.failure;
  EXPECT_EQ(testing::boundary_halfedges(mesh), boundary_before);
}

// The test of picked points: on the rocker arm's crease hole, four points picked on the
// crease retain it closer to the ground truth than the plain fill, in Hausdorff and mean
// distance, with both variants (measured: plain 12.06 / 2.42‰, split 8.59 / 1.23‰, push-down
// with the default fairing 8.78 / 1.22‰).
TEST(SharpCasesPicked, PointsPickedOnTheCreaseRetainItCloserThanThePlainFill) {
  std::string error;
  const auto c = testing::load_case("rocker-arm_sharp", error);
  ASSERT_TRUE(c) << error;
  const auto s_plain = plain_fill_score(*c, 0);
  ASSERT_TRUE(s_plain);
  for (const SharpenMethod method : {SharpenMethod::Split, SharpenMethod::PushDown}) {
    SharpenOptions options;
    options.method = method;
    const PickedScore picked = sharpen_picked(*c, 0, options);
    ASSERT_TRUE(picked.result.ok) << to_string(method) << ": " << picked.result.failure;
    EXPECT_TRUE(picked.result.crease_tangent_start && picked.result.crease_tangent_end);
    EXPECT_LT(picked.score.hausdorff_permille, s_plain->hausdorff_permille - 2.0)
        << to_string(method);
    EXPECT_LT(picked.score.mean_permille, s_plain->mean_permille - 0.5) << to_string(method);
  }
}

// Seed 000 §5: a pick off the crease biases the thesis' curve. On the fandisk's straight crease
// hole, P1 and P4 picked one edge length beside the crease: the chord tangents tilt the curve
// off the true crease (measured 1.9‰), the crease's own tangents put it exactly on it.
TEST(SharpCasesPicked, CreaseTangentsAreNotBiasedByAPickBesideTheCrease) {
  std::string error;
  const auto c = testing::load_case("fandisk_sharp", error);
  ASSERT_TRUE(c) << error;
  SharpenOptions options;
  options.method = SharpenMethod::Split;
  const PickedScore crease = sharpen_picked(*c, 0, options, 1.0);
  ASSERT_TRUE(crease.result.ok) << crease.result.failure;
  EXPECT_TRUE(crease.result.crease_tangent_start && crease.result.crease_tangent_end);
  EXPECT_LE(crease.score.crease_permille, 0.05);
  EXPECT_LE(crease.score.mean_permille, 0.05);
  options.tangents = PickTangents::Chord;
  const PickedScore chord = sharpen_picked(*c, 0, options, 1.0);
  ASSERT_TRUE(chord.result.ok) << chord.result.failure;
  EXPECT_FALSE(chord.result.crease_tangent_start || chord.result.crease_tangent_end);
  EXPECT_GT(chord.score.crease_permille, crease.score.crease_permille + 0.5);
  EXPECT_NE(tangents_summary(crease.result.crease_tangent_start, crease.result.crease_tangent_end,
                             PickTangents::Crease)
                .find("both ends"),
            std::string::npos);
}

// Beyond the thesis' one curve: every crease of a hole picked. fandisk_sharp #1 is a corner cut
// away (a crease pair and three creases meeting inside), couplingdown_sharp #2 five creases
// meeting at three corners, couplingdown_sharp #1 three rings; one picked pair cannot follow
// either (fandisk #1: 26.98 per mille, no closer than the plain fill), every crease picked is
// closer than the plain fill in Hausdorff and mean distance (measured: fandisk #1 9.23 / 0.71
// against 26.98 / 4.87, couplingdown #2 5.64 / 1.43 against 14.33 / 3.15 per mille), and the
// corners' creases are retained within 3 per mille (fandisk 0.90, couplingdown #2 2.54).
TEST(SharpCasesPicked, EveryCreasePickedRetainsACornerCloserThanThePlainFill) {
  for (const auto& [name, case_hole] : {std::pair<std::string, std::size_t>{"fandisk_sharp", 1},
                                        {"couplingdown_sharp", 2},
                                        {"couplingdown_sharp", 1}}) {
    std::string error;
    const auto c = testing::load_case(name, error);
    ASSERT_TRUE(c) << error;
    const auto s_plain = plain_fill_score(*c, case_hole);
    ASSERT_TRUE(s_plain) << name;
    const PickedScore every = sharpen_picked(*c, case_hole, {}, 0, PickScope::EveryCrease);
    ASSERT_TRUE(every.result.ok) << name << ": " << every.result.failure;
    EXPECT_LT(every.score.hausdorff_permille, s_plain->hausdorff_permille - 2.0) << name;
    EXPECT_LT(every.score.mean_permille, s_plain->mean_permille - 0.2) << name;
    // couplingdown #1's creases are rings: each picked pair is followed as the arc both of its
    // creases continue, the boss-top ring too, whose picked rim vertices have no crease of their
    // own (the ring runs along the rim to them; measured 7.91 / 0.67, crease 0.51 per mille,
    // against the plain 22.86 / 3.82 / 20.65; as Hermite curves 23.06 / 4.12 with three rings).
    if (name == "couplingdown_sharp" && case_hole == 1) {
      EXPECT_EQ(every.result.arcs, 6);
      EXPECT_EQ(every.result.crease_tangents_taken, 12);
      EXPECT_LE(every.score.crease_permille, 3.0);
    }
    if (name == "couplingdown_sharp" && case_hole == 2) {
      EXPECT_LE(every.score.crease_permille, 3.0);
    }
    if (name == "fandisk_sharp") {
      ASSERT_TRUE(every.result.corner);
      EXPECT_EQ(every.result.crease_tangents_taken, 5);  // the pair's two ends, three creases
      EXPECT_LE(every.score.crease_permille, 3.0);
    }
  }
}

// DESIGN's smallest angle of 15°. On the rocker arm's 264-vertex hole the settling after the
// second fairing leaves a cap whose obtuse corner fairing pulled against a rim edge (13.8°); on
// couplingdown_sharp #0 (split along its crease, each side faired) a needle between a curve
// sample and the rim (14.97° when the last pass worked only on the triangles under 15°: their
// neighbours must make room too). The last pass mends both (measured 17.8° and 15.6°) without
// moving the patch off the ground truth. fandisk_sharp #1's crease split is flat (a CAD part),
// and one region spans a boundary that is not quite planar: its triangulation folds by 12°
// across an edge with a 153° cap beside it. A flat patch's mending flips across soft folds up
// to 15° (a crease bends by at least 30°), so the cap is mended (measured 11.3° with 10°, 18.0°
// with 15°) and the patch stays as close (mean 0.71 per mille). What all the passes leave under
// 15° beside a short edge nothing may move (a crease segment, a rim edge) gets a graded
// refinement by off-centres that may split the crease segments (refine_graded):
// couplingdown_sharp #2's needle between a 0.0099 link of two crease corners and a rim vertex
// 0.05 away (9.9° before), couplingdown_sml #2's cap beside a rim edge (13.1° before; its new
// vertices must step off a 0.29-long rim edge they would encroach on), couplingdown_sml #1's
// rim corner beside a chord flipped to follow the rim (14.7° before, while the flipped
// triangle kept the region it was cut from). couplingdown_sml #1's bound is the best anchor's
// mean (3.39 per mille; its fillet, SharpCasesRounded below).
TEST(HoleCaseQuality, CapsLeftUnderFifteenDegreesAreMended) {
  struct Expected {
    const char* name;
    std::size_t case_hole;
    PatchShape shape;
    double mean_below;  // the best anchor's mean distance (BASELINE.md) or tighter, or below
  };
  for (const Expected& e : {Expected{"rocker-arm_xl", 0, PatchShape::Fair, 21.5},
                            Expected{"couplingdown_sharp", 0, PatchShape::Fair, 4.61},
                            Expected{"fandisk_sharp", 1, PatchShape::Flat, 1.0},
                            Expected{"couplingdown_sharp", 2, PatchShape::Fair, 3.55},
                            Expected{"couplingdown_sml", 2, PatchShape::Fair, 6.70},
                            Expected{"couplingdown_sml", 1, PatchShape::Fair, 3.39}}) {
    SCOPED_TRACE(e.name);
    const auto loaded = load_case_mesh(e.name, e.case_hole);
    ASSERT_TRUE(loaded);
    auto& [c, mesh, holes, hole] = *loaded;
    const testing::Snapshot before = testing::take_snapshot(mesh);
    const HoleFillReport r = fill_hole(mesh, *hole, FillOptions{});
    ASSERT_TRUE(r.filled) << r.reason;
    EXPECT_EQ(r.shape, e.shape);
    EXPECT_TRUE(testing::check_fill_invariants(before, mesh, {r}, holes).empty());
    EXPECT_GE(r.min_angle_deg, 15.0);
    const auto s = testing::score_fill(mesh, r, c, c.holes.at(e.case_hole));
    EXPECT_LT(s.mean_permille, e.mean_below);
  }
}

//! Fills \p hole (case hole \p case_hole of \p c) with `SharpMode::Auto`, expecting the crease
//! split and every fill invariant; the patch's score.
std::optional<testing::HoleScore> crease_split_score(Mesh& mesh, const Hole& hole,
                                                     const std::vector<Hole>& holes,
                                                     const testing::HoleCase& c,
                                                     std::size_t case_hole,
                                                     std::optional<std::size_t> curves = {}) {
  FillOptions options;
  options.sharp = SharpMode::Auto;
  const testing::Snapshot before = testing::take_snapshot(mesh);
  const HoleFillReport r = fill_hole(mesh, hole, options);
  EXPECT_TRUE(r.filled) << r.reason;
  if (!r.filled) return std::nullopt;
  EXPECT_EQ(r.method, FillMethod::CreaseSplit) << r.creases;
  if (curves) {
    EXPECT_EQ(r.crease_curves, *curves) << r.shape_reason;
  }
  EXPECT_TRUE(testing::check_fill_invariants(before, mesh, {r}, holes).empty());
  return testing::score_fill(mesh, r, c, c.holes.at(case_hole));
}

// couplingdown_sharp #1 cuts across a boss and a bore: its creases are six rings (one turning
// 290 deg inside the hole, both edges of a 45 deg chamfer, which count as creases because they
// stand out cleanly, and the boss's top edge; the chamfer's upper edge and the boss's top edge
// run along the rim for an edge before they cross the hole: no sharp edge leaves the rim where
// they cross, plan_hole_creases follows the rim to find them). Joined by circular arcs
// (crease_arc_between), the split fill is closer to the ground truth than the plain fill everywhere
// the test can see, and every crease is retained within 3 per mille (measured: H 6.97 vs 22.86 per
// mille, mean 0.59 vs 3.82, crease 0.51 vs 20.65; without the boss-top ring 13.17 / 1.19 / 13.17;
// with three rings 16.70 / 2.30; before arcs the detection paired creases of different rings, and
// the split crossed the mesh).
TEST(SharpCasesArcs, RingCreasesAreJoinedByArcsAndTheSplitIsCloser) {
  const auto loaded = load_case_mesh("couplingdown_sharp", 1);
  ASSERT_TRUE(loaded);
  auto& [c, mesh, holes, found] = *loaded;
  const Hole& hole = *found;
  const HoleCreasePlan plan = plan_hole_creases(mesh, hole, {});
  std::size_t arcs = 0;
  for (const CreaseCurve& curve : plan.curves) arcs += curve.arc ? 1 : 0;
  EXPECT_EQ(arcs, 6u) << plan.summary;
  // The boss-top ring and the chamfer's upper edge: both crossings of each found by following
  // the rim (one edge each).
  std::size_t along_rim = 0;
  for (const CreaseCurve& curve : plan.curves)
    if (curve.arc && curve.to && plan.crossings[curve.from].rim_run == 1 &&
        plan.crossings[*curve.to].rim_run == 1)
      ++along_rim;
  EXPECT_EQ(along_rim, 2u) << plan.summary;
  const auto s_plain = plain_fill_score(c, 1);
  ASSERT_TRUE(s_plain);
  const auto scored = crease_split_score(mesh, hole, holes, c, 1);
  ASSERT_TRUE(scored);
  const testing::HoleScore& s = *scored;
  EXPECT_LT(s.hausdorff_permille, s_plain->hausdorff_permille - 6.0);
  EXPECT_LT(s.mean_permille, s_plain->mean_permille - 2.0);
  EXPECT_LE(s.crease_permille, 3.0) << "plain " << s_plain->crease_permille;
}

// couplingdown_sml #1 cuts the corner where a bore's wall turns into its ceiling through a
// fillet of three thin facets, whose edges bend by 15-30° each: no edge of it is a crease, and
// a fill across it cut the corner (mean 11.10 per mille, Hausdorff 43.89; every anchor closer,
// the best 3.39). Its band crosses the rim at four vertices 0.004 apart on each side of the
// hole (the rim's mean edge is 0.035); the plan takes each band as one crease of the band's
// whole turn (90°), crossing at its middle, pairs the two and splits along their curve, so the
// wall and the ceiling are each filled on their own (measured 6.51 / 1.80).
TEST(SharpCasesRounded, AFilletCrossingTheRimIsPairedAsOneCrease) {
  const auto loaded = load_case_mesh("couplingdown_sml", 1);
  ASSERT_TRUE(loaded);
  auto& [c, mesh, holes, found] = *loaded;
  const Hole& hole = *found;
  const HoleCreasePlan plan = plan_hole_creases(mesh, hole, {});
  std::size_t fillets = 0;
  for (const CreaseCurve& curve : plan.curves) {
    if (!curve.to) continue;
    const CreaseCrossing& a = plan.crossings[curve.from];
    const CreaseCrossing& b = plan.crossings[*curve.to];
    // The bands' turns: the sum of their four soft edges, no edge of which is over 30°.
    if (a.dihedral_deg > 80 && b.dihedral_deg > 80 && !a.convex && !b.convex) ++fillets;
  }
  EXPECT_EQ(fillets, 1u) << plan.summary;
  const auto s_plain = plain_fill_score(c, 1);
  ASSERT_TRUE(s_plain);
  const auto scored = crease_split_score(mesh, hole, holes, c, 1);
  ASSERT_TRUE(scored);
  EXPECT_LT(scored->mean_permille, 3.39) << "plain " << s_plain->mean_permille;
  EXPECT_LT(scored->hausdorff_permille, 0.5 * s_plain->hausdorff_permille);
}

// couplingdown_sharp #2 cuts a box edge where a chamfer meets it: the two top creases (90°)
// curve into corner A, a vertical edge drops from it to B, where one of the chamfer's creases
// (45°) ends, and a short edge leads on to C, where the chamfer's other crease and the step's
// edge (90°) meet. No two of them pair (a 90° crease does not go on as a 45° one). A and C lie
// where their creases, continued with the bend fitted near the rim, come closest; B where its
// crease and the two edges leaving A and C (each the meeting of the faces beside its corner's
// outer creases) come closest. Measured: H / mean / crease 5.64 / 1.43 / 2.54 per mille against
// the plain fill's 14.33 / 3.38 / 12.93; two corners (B and C as one) 3.82 / 1.48 / 3.74, and
// with the tangent fitted over the whole fit length instead of the bend's 8.52 / 1.45 / 8.52.
TEST(SharpCasesCorners, CreasesOfABoxEdgeAndAChamferMeetAtThreeCorners) {
  const auto loaded = load_case_mesh("couplingdown_sharp", 2);
  ASSERT_TRUE(loaded);
  auto& [c, mesh, holes, found] = *loaded;
  const Hole& hole = *found;
  const HoleCreasePlan plan = plan_hole_creases(mesh, hole, {});
  ASSERT_EQ(plan.corners.size(), 3u) << plan.summary;
  ASSERT_EQ(plan.corner_links.size(), 2u);
  std::array<std::size_t, 3> creases_at{0, 0, 0};
  for (const CreaseCurve& curve : plan.curves) {
    EXPECT_FALSE(curve.to) << "a pair: " << plan.summary;
    ++creases_at.at(curve.corner);
  }
  // A path A - B - C: the middle corner holds both links and the one chamfer crease.
  std::array<std::size_t, 3> links_at{0, 0, 0};
  for (const auto& [a, b] : plan.corner_links) {
    ++links_at.at(a);
    ++links_at.at(b);
  }
  for (std::size_t k = 0; k < 3; ++k) {
    EXPECT_EQ(creases_at[k] + links_at[k], 3u) << "corner " << k << ": " << plan.summary;
    EXPECT_EQ(creases_at[k], links_at[k] == 2 ? 1u : 2u) << "corner " << k;
  }
  const auto s_plain = plain_fill_score(c, 2);
  ASSERT_TRUE(s_plain);
  // The report counts every curve the patch is split along: the creases and the two links.
  const auto scored =
      crease_split_score(mesh, hole, holes, c, 2, plan.curves.size() + plan.corner_links.size());
  ASSERT_TRUE(scored);
  EXPECT_LT(scored->hausdorff_permille, s_plain->hausdorff_permille - 4.0);
  EXPECT_LT(scored->mean_permille, s_plain->mean_permille - 1.5);
  EXPECT_LE(scored->crease_permille, 3.0);  // issue 5's bound
}

// fandisk_sml #1: a straight edge of the part runs along the rim for two edges, crosses the hole
// and runs along the rim again; both crossings' tangents lie within 5 deg of the chord between
// them (3.3 and 1.6 deg). Crossings found along the rim pair only along arcs, or, like these,
// along the chord itself: the curve is that chord (both ends lie on the edge), not a Hermite
// curve of the fitted tangents (which moved the mean 0.00 -> 0.06 per mille here). Measured:
// mean 0.00 either way, H 0.17 (plain fill, whose rim-to-rim edge happened to lie on the edge)
// -> 0.22 per mille, smallest angle 26.2 -> 24.1 deg.
TEST(SharpCasesStraight, AStraightEdgeLeavingTheRimIsJoinedByItsChord) {
  const auto loaded = load_case_mesh("fandisk_sml", 1);
  ASSERT_TRUE(loaded);
  auto& [c, mesh, holes, found] = *loaded;
  const Hole& hole = *found;
  const HoleCreasePlan plan = plan_hole_creases(mesh, hole, {});
  const CreaseCurve* chord = nullptr;
  for (const CreaseCurve& curve : plan.curves)
    if (curve.to && plan.crossings[curve.from].rim_run > 0 && plan.crossings[*curve.to].rim_run > 0)
      chord = &curve;
  ASSERT_TRUE(chord) << plan.summary;
  EXPECT_FALSE(chord->arc);
  const Vec3 a = plan.crossings[chord->from].position, b = plan.crossings[*chord->to].position;
  for (double t = 0.1; t < 1.0; t += 0.1) {
    const Vec3 q = chord->curve.at(t);
    EXPECT_LT(std::sqrt(segment_segment_distance2(q, q, a, b)), 1e-9 * (b - a).norm());
  }
  const auto scored = crease_split_score(mesh, hole, holes, c, 1);
  ASSERT_TRUE(scored);
  EXPECT_LT(scored->mean_permille, 0.01);
  EXPECT_LT(scored->hausdorff_permille, 0.5);
}

// couplingdown_sml #2: the bottom ring of a bore meets the hole at two crossings a 315 deg arc
// apart, but the rim itself follows that ring for most of the way; only the stretch across the
// hole is a curve (between the boundary vertices where the ring leaves the rim). The split along
// it keeps the ring (measured: crease 2.80 against the plain fill's 12.78 per mille; the whole
// arc laid regions over the surrounding surface and both splits crossed the mesh). The outer
// wall's 45 deg chamfers are clean creases too: with them the fill is closer than every anchor
// of BASELINE.md (mean 4.80 per mille, MeshLab's 6.70; H 24.05, 82.16 without them). One
// chamfer ring runs along the rim before it crosses; its arc meets the arc of two short chamfer
// creases near the middle, and of two curves that meet the planner keeps the better (with both
// the split is non-manifold and the plain fill's 10.75 per mille stood).
TEST(SharpCasesArcs, ARingTheRimFollowsIsCutToItsStretchAcrossTheHole) {
  const auto loaded = load_case_mesh("couplingdown_sml", 2);
  ASSERT_TRUE(loaded);
  auto& [c, mesh, holes, found] = *loaded;
  const Hole& hole = *found;
  const HoleCreasePlan plan = plan_hole_creases(mesh, hole, {});
  // The bore's ring: the arc between the two 90 deg valley crossings.
  const CreaseArc* ring = nullptr;
  for (const CreaseCurve& curve : plan.curves)
    if (curve.arc && curve.to && !plan.crossings[curve.from].convex &&
        plan.crossings[curve.from].dihedral_deg > 60)
      ring = &*curve.arc;
  ASSERT_TRUE(ring) << plan.summary;
  EXPECT_LT(ring->angle, std::numbers::pi) << "the whole 315 deg ring was kept";
  // The middle of the curve is across the hole, well off the rim.
  const Vec3 middle = ring->at(0.5);
  double to_rim = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < hole.loop.size(); ++i)
    to_rim = std::min(to_rim, std::sqrt(segment_segment_distance2(
                                  middle, middle, mesh.point(hole.loop[i]),
                                  mesh.point(hole.loop[(i + 1) % hole.loop.size()]))));
  EXPECT_GT(to_rim, 0.5 * hole.mean_edge_length);
  std::size_t chamfer_curves = 0;
  for (const CreaseCurve& curve : plan.curves)
    chamfer_curves += curve.to && plan.crossings[curve.from].dihedral_deg < 50 &&
                              plan.crossings[*curve.to].dihedral_deg < 50
                          ? 1
                          : 0;
  EXPECT_GE(chamfer_curves, 1u) << plan.summary;
  // A pin's base ring (radius 0.035) crosses the hole by 160° and runs along the rim for the
  // other 200°: its bend is fitted over the first quarter turn only (over the whole rim run the
  // parabola measured κ 5.2 for the ring's 28.6 and the arc was refused), and its ends are
  // joined by its arc.
  bool pin_ring = false;
  for (const CreaseCurve& curve : plan.curves)
    pin_ring |= curve.arc && std::abs(curve.arc->radius - 0.035) < 0.0035;
  EXPECT_TRUE(pin_ring) << plan.summary;
  const auto s_plain = plain_fill_score(c, 2);
  ASSERT_TRUE(s_plain);
  const auto scored = crease_split_score(mesh, hole, holes, c, 2);
  ASSERT_TRUE(scored);
  const testing::HoleScore& s = *scored;
  EXPECT_LT(s.crease_permille, 7.0) << "plain " << s_plain->crease_permille;
  EXPECT_LT(s.hausdorff_permille, s_plain->hausdorff_permille - 20.0);
  EXPECT_LT(s.mean_permille, s_plain->mean_permille - 3.0);
  EXPECT_LT(s.mean_permille, 6.70);  // BASELINE.md's best anchor (MeshLab)
}

std::vector<std::string> sharp_cases() {
  std::vector<std::string> out;
  for (const std::string& name : testing::list_cases())
    if (name.find("_sharp") != std::string::npos) out.push_back(name);
  return out;
}

INSTANTIATE_TEST_SUITE_P(SharedData, SharpCases, ::testing::ValuesIn(sharp_cases()),
                         [](const auto& param_info) {
                           std::string name = param_info.param;
                           for (char& ch : name)
                             if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
                           return name;
                         });

TEST(HoleCasesData, SharedDataIsPresent) {
  // The suite above would silently run zero cases without the data: make that a failure.
  EXPECT_GE(testing::list_cases().size(), 10u) << "no cases under " << testing::shared_data_dir();
  EXPECT_EQ(sharp_cases().size(), 3u);
}

// The auto shape on the coarse hand (hand_sml): large bends at the boundary there are the
// coarse tessellation of a curved surface, not creases of a CAD part. Hole 0 is faired and ends
// closer to the ground truth than the flat fill; hole 2 straddles the rim of the flat wrist cap,
// where fairing balloons into a dome (BASELINE.md): the balloon guard keeps it flat, closer to
// the ground truth than the faired patch it refused.
TEST(HoleCasesShape, CoarseCurvedSurfaceIsFairedAndBalloonsStayFlat) {
  std::string error;
  const auto c = testing::load_case("hand_sml", error);
  ASSERT_TRUE(c) << error;
  const auto fill_case_hole = [&](int case_hole, const FillOptions& options) {
    Mesh mesh = build_mesh(c->holed).mesh;
    const auto holes = find_holes(mesh).holes;
    const auto id =
        testing::matching_hole_id(holes, c->holes.at(static_cast<std::size_t>(case_hole)));
    EXPECT_TRUE(id);
    FillSelection one;
    one.mode = FillSelection::Mode::Ids;
    one.ids = {*id};
    const FillReport report = fill_holes(mesh, one, options);
    EXPECT_EQ(report.holes.size(), 1u);
    const HoleFillReport& r = report.holes.at(0);
    EXPECT_TRUE(r.filled) << r.reason;
    return std::pair{
        r, testing::score_fill(mesh, r, *c, c->holes.at(static_cast<std::size_t>(case_hole)))};
  };
  FillOptions flat;
  flat.shape = PatchShape::Flat;
  FillOptions fair;
  fair.shape = PatchShape::Fair;
  fair.max_fair_bulge = 1e9;  // no guard

  const auto [auto0, auto0_score] = fill_case_hole(0, {});
  const auto [flat0, flat0_score] = fill_case_hole(0, flat);
  EXPECT_EQ(auto0.shape, PatchShape::Fair) << auto0.shape_reason;
  EXPECT_LT(auto0_score.mean_permille, flat0_score.mean_permille);

  const auto [auto2, auto2_score] = fill_case_hole(2, {});
  const auto [fair2, fair2_score] = fill_case_hole(2, fair);
  EXPECT_EQ(fair2.shape, PatchShape::Fair);
  EXPECT_EQ(auto2.shape, PatchShape::Flat) << auto2.shape_reason;
  bool warned = false, skipped = false;
  for (const auto& w : auto2.warnings) {
    warned = warned || w.find("balloon") != std::string::npos;
    skipped = skipped || w.find("piecewise: not faired") != std::string::npos;
  }
  EXPECT_TRUE(warned);
  // It balloons well past the limit, so the other method's faired patch is not built.
  EXPECT_GT(auto2.fair_bulge, 1.5 * FillOptions{}.max_fair_bulge);
  EXPECT_TRUE(skipped);
  EXPECT_LT(auto2_score.mean_permille, 0.75 * fair2_score.mean_permille);
}

//! A real-hole case's mesh with hole \p id (find_holes numbering) filled with the defaults;
//! none (with the failure reported) unless that one hole was filled.
struct RealHoleFill {
  Mesh mesh;
  std::vector<Hole> holes;  //!< before the fill
  testing::Snapshot before;
  FillReport report;
};
std::optional<RealHoleFill> fill_real_hole(const std::string& name, std::uint32_t id) {
  std::string error;
  const auto c = testing::load_case(name, error);
  EXPECT_TRUE(c) << error;
  if (!c) return std::nullopt;
  RealHoleFill out;
  out.mesh = build_mesh(c->holed).mesh;
  out.holes = find_holes(out.mesh).holes;
  out.before = testing::take_snapshot(out.mesh);
  FillSelection one;
  one.mode = FillSelection::Mode::Ids;
  one.ids = {id};
  out.report = fill_holes(out.mesh, one, {});
  EXPECT_EQ(out.report.holes.size(), 1u);
  if (out.report.holes.size() != 1) return std::nullopt;
  EXPECT_TRUE(out.report.holes[0].filled) << out.report.holes[0].reason;
  if (!out.report.holes[0].filled) return std::nullopt;
  return out;
}

// Just past the balloon limit the triangulation decides: mech-holes-shark's hole 7 balloons
// (0.51 hole radii) as the 3D triangulation's faired patch, and the piecewise method's faired
// patch, which stays under the limit, is built and kept.
TEST(HoleCasesShape, NearTheBalloonLimitTheOtherMethodIsFaired) {
  const auto fill = fill_real_hole("mech-holes-shark_real", 7);
  ASSERT_TRUE(fill);
  const HoleFillReport& r = fill->report.holes[0];
  EXPECT_EQ(r.shape, PatchShape::Fair);
  EXPECT_EQ(r.method, FillMethod::Piecewise);
  bool ballooned = false;
  for (const auto& w : r.warnings) ballooned = ballooned || w.find("balloon") != std::string::npos;
  EXPECT_TRUE(ballooned);
  EXPECT_LE(r.fair_bulge, FillOptions{}.max_fair_bulge);
}

// A fifth past the limit the surroundings decide: mech-holes-shark's hole 1 balloons 0.61 hole
// radii as the planar triangulation's faired patch (the 3D triangulation's rose 0.60), so the
// 3D triangulation's faired patch is not built and the planar patch is kept flat.
TEST(HoleCasesShape, WellPastTheBalloonLimitNoOtherMethodIsFaired) {
  const auto fill = fill_real_hole("mech-holes-shark_real", 1);
  ASSERT_TRUE(fill);
  const HoleFillReport& r = fill->report.holes[0];
  EXPECT_EQ(r.shape, PatchShape::Flat) << r.shape_reason;
  EXPECT_EQ(r.method, FillMethod::Planar);
  EXPECT_GT(r.fair_bulge, 1.2 * FillOptions{}.max_fair_bulge);
  bool skipped = false;
  for (const auto& w : r.warnings)
    skipped = skipped || w.find("minimum-weight-3d: not faired") != std::string::npos;
  EXPECT_TRUE(skipped);
}

// stanford-bunny's real hole 1884 has a 55° rim corner between edges 0.00035 and 0.0030 long:
// only a fan of three triangles at that corner, each within a degree of 15° and growing by
// about 2.06, gets every angle to 15° (11.7° before the graded refinement's corner fans).
TEST(HoleCaseQuality, NarrowRimCornerOfARealHoleGetsAGradedFan) {
  const auto fill = fill_real_hole("stanford-bunny_real", 1884);
  ASSERT_TRUE(fill);
  const HoleFillReport& r = fill->report.holes[0];
  EXPECT_EQ(r.shape, PatchShape::Fair);
  const std::string problems =
      testing::check_fill_invariants(fill->before, fill->mesh, fill->report.holes, fill->holes);
  EXPECT_TRUE(problems.empty()) << problems;
  EXPECT_GE(r.min_angle_deg, 15.0);
}

//! One hole cut into a shared mesh (the faces whose centroid lies within \p radius of \p centre),
//! its rim changed by \p damage if given, and filled with the defaults.
struct CutFill {
  Mesh mesh;
  std::vector<Hole> holes;
  testing::Snapshot before;
  FillReport report;
  std::vector<TrianglePoints> removed;  //!< the cut faces: the ground truth
  double diagonal = 0;                  //!< of the mesh's bounding box
};

std::optional<CutFill> fill_one_cut(const std::string& mesh_name,
                                    const std::function<bool(const Vec3&)>& removed_centroid,
                                    const std::function<void(MeshSoup&)>& damage = {}) {
  const auto read = read_mesh_file(testing::shared_data_dir() + "/meshes/" + mesh_name);
  EXPECT_TRUE(read.ok) << read.error;
  if (!read.ok) return std::nullopt;
  CutFill out;
  Box3 box;
  for (const Vec3& p : read.soup.points) box.extend(Eigen::Vector3d(p[0], p[1], p[2]));
  out.diagonal = box.diagonal().norm();
  std::vector<std::array<Vec3, 3>> removed;
  MeshSoup holed = testing::remove_faces(read.soup, removed_centroid, &removed);
  if (damage) damage(holed);
  for (const auto& t : removed) out.removed.push_back({t[0], t[1], t[2]});
  out.mesh = build_mesh(holed).mesh;
  out.holes = find_holes(out.mesh).holes;
  EXPECT_EQ(out.holes.size(), 1u);
  out.before = testing::take_snapshot(out.mesh);
  out.report = fill_holes(out.mesh, {}, {});
  EXPECT_EQ(out.report.holes.size(), 1u);
  if (out.holes.size() != 1 || out.report.holes.size() != 1) return std::nullopt;
  EXPECT_TRUE(out.report.holes[0].filled) << out.report.holes[0].reason;
  if (!out.report.holes[0].filled) return std::nullopt;
  const std::string problems =
      testing::check_fill_invariants(out.before, out.mesh, out.report.holes, out.holes);
  EXPECT_TRUE(problems.empty()) << problems;
  return out;
}

//! fill_one_cut of the faces whose centroids lie within \p radius of \p centre.
std::optional<CutFill> fill_one_cut(const std::string& mesh_name, const Vec3& centre, double radius,
                                    const std::function<void(MeshSoup&)>& damage = {}) {
  return fill_one_cut(
      mesh_name, [&](const Vec3& c) { return (c - centre).norm() < radius; }, damage);
}

//! fill_one_cut of the faces whose centroids lie within \p radius of the polyline \p path (a
//! slot, as the crease-slot bench cuts them along a crease).
std::optional<CutFill> fill_slot_cut(const std::string& mesh_name, const std::vector<Vec3>& path,
                                     double radius) {
  return fill_one_cut(mesh_name, [&](const Vec3& c) {
    for (std::size_t i = 0; i + 1 < path.size(); ++i)
      if (segment_segment_distance2(c, c, path[i], path[i + 1]) < radius * radius) return true;
    return false;
  });
}

// A hole cut into fandisk (the faces within 0.445 of a point near a crease): its patch stays
// flat, and after every pass one triangle was left at 13.2°. The graded refinement, keeping
// the flat patch's surface, mends it (17.6°).
TEST(HoleCaseQuality, FlatPatchLeftUnderFifteenDegreesIsRefinedInItsSurface) {
  const auto cut =
      fill_one_cut("fandisk.obj", Vec3(2.81237, 16.089899, -0.788448), 0.4449894976692565);
  ASSERT_TRUE(cut);
  const HoleFillReport& r = cut->report.holes[0];
  EXPECT_EQ(r.shape, PatchShape::Flat) << r.shape_reason;
  EXPECT_GE(r.min_angle_deg, 15.0);
}

// A hole cut into fandisk across a face and the corner of another (the faces within 0.589 of a
// vertex): the plan splits it along the one crease it can pair, and leaves two crossings
// unmatched, whose bends run into the flat regions. Their spanning triangulations folded there
// into fans of slivers (18 triangles under 15°, down to 3.5°) that keeping every fold could not
// mend. A crease split's flat region has no fold worth keeping (hole_filling.cpp, mend): with
// its folds mended the fill has no triangle under 15° and is no farther from the removed faces.
TEST(HoleCaseQuality, CreaseSplitFlatRegionsMendTheirFolds) {
  const auto cut = fill_one_cut("fandisk.obj", Vec3(0, 14.9066, -1.64063), 0.58930784135394643);
  ASSERT_TRUE(cut);
  const HoleFillReport& r = cut->report.holes[0];
  EXPECT_EQ(r.method, FillMethod::CreaseSplit) << r.creases;
  EXPECT_EQ(r.shape, PatchShape::Flat) << r.shape_reason;
  EXPECT_GE(r.min_angle_deg, 15.0);
  const SurfaceDistance d =
      surface_distance(face_triangles(cut->mesh, r.new_faces), cut->removed, 0.002 * cut->diagonal);
  ASSERT_TRUE(d.valid);
  // 6.52‰ with every fold kept (the corner the unmatched creases make is not modelled).
  EXPECT_LE(1000 * d.mean / cut->diagonal, 6.52);
}

//! The sharp edges (dihedral over 60°, the referee's) among \p triangles: the edges two of them
//! share, found by their corners' positions.
std::vector<std::array<Vec3, 2>> creases_among(const std::vector<TrianglePoints>& triangles) {
  std::map<std::array<double, 6>, std::vector<Vec3>> normals_by_edge;
  for (const TrianglePoints& t : triangles) {
    const Vec3 normal = OpenMesh::cross(t[1] - t[0], t[2] - t[0]).normalize_cond();
    for (int k = 0; k < 3; ++k) {
      Vec3 a = t[k], b = t[(k + 1) % 3];
      if (std::lexicographical_compare(b.data(), b.data() + 3, a.data(), a.data() + 3))
        std::swap(a, b);
      normals_by_edge[{a[0], a[1], a[2], b[0], b[1], b[2]}].push_back(normal);
    }
  }
  std::vector<std::array<Vec3, 2>> out;
  const double sharp_cos = std::cos(60.0 * std::numbers::pi / 180);
  for (const auto& [edge, normals] : normals_by_edge)
    if (normals.size() == 2 && OpenMesh::dot(normals[0], normals[1]) < sharp_cos)
      out.push_back({Vec3(edge[0], edge[1], edge[2]), Vec3(edge[3], edge[4], edge[5])});
  return out;
}

//! The distances of \p cut's patch (its one hole's new faces) from the removed faces, per mille
//! of the diagonal: the mean distance and the largest distance of a removed crease (creases_among)
//! from the patch; NaN where one cannot be measured (a bound on it then fails).
struct PatchDistances {
  double mean = std::numeric_limits<double>::quiet_NaN();
  double crease = std::numeric_limits<double>::quiet_NaN();
};
PatchDistances patch_distances(const CutFill& cut) {
  const auto patch = face_triangles(cut.mesh, cut.report.holes[0].new_faces);
  PatchDistances out;
  const SurfaceDistance d = surface_distance(patch, cut.removed, 0.002 * cut.diagonal);
  if (d.valid) out.mean = 1000 * d.mean / cut.diagonal;
  const SegmentDistance creases =
      segment_distance(creases_among(cut.removed), patch, 0.002 * cut.diagonal);
  if (creases.valid) out.crease = 1000 * creases.max / cut.diagonal;
  return out;
}

//! The one hole of \p cut, checked as a crease split's fill: split along its creases, no
//! triangle under DESIGN's 15°, within \p max_mean per mille of the removed faces on average.
const HoleFillReport& expect_crease_split_fill(const CutFill& cut, double max_mean) {
  const HoleFillReport& r = cut.report.holes[0];
  EXPECT_EQ(r.method, FillMethod::CreaseSplit) << r.creases;
  EXPECT_GE(min_angle_deg(cut.mesh, r.new_faces), 15.0) << r.creases;
  EXPECT_LE(patch_distances(cut).mean, max_mean) << r.creases;
  return r;
}

// A slot cut into fandisk along the straight ridge between two corners and on along the curved
// top ridge (the faces within 0.11 of that path, as the cut bench's slots along creases take
// them): at the upper corner the straight ridge meets another ridge and a valley, at the lower
// one the curved ridge. Where the curved ridge leaves the slot, 0.7 from its corner, its tangent
// line misses the corner by more than the corner tolerance, and the plan found no corner: the
// 3D triangulation spanned the slot, 10.4‰ off the ridges on the bench's slot. Its bent crease,
// fitted along it at the rim, passes the corner: the plan joins the four creases at two corners
// and the split keeps the ridges.
TEST(HoleCaseQuality, ACurvedCreaseMeetsItsCornerAlongItsBend) {
  const Vec3 upper(4.8279, 14.4517, -0.3905), lower(4.8279, 14.3678, -0.8666),
      along_curve(4.1646, 14.3435, -1.0044);
  const auto cut = fill_slot_cut("fandisk.obj", {upper, lower, along_curve}, 0.11);
  ASSERT_TRUE(cut);
  const HoleFillReport& r = cut->report.holes[0];
  EXPECT_EQ(r.method, FillMethod::CreaseSplit) << r.creases;
  EXPECT_NE(r.creases.find("at 2 corners"), std::string::npos) << r.creases;
  const std::vector<std::array<Vec3, 2>> creases = creases_among(cut->removed);
  ASSERT_GE(creases.size(), 10u);
  const SegmentDistance d =
      segment_distance(creases, face_triangles(cut->mesh, r.new_faces), 0.002 * cut->diagonal);
  ASSERT_TRUE(d.valid);
  EXPECT_LE(1000 * d.max / cut->diagonal, 3.0);
}

//! fill_slot_cut of fandisk along \p path: the hole is split along its creases as \p plan says
//! (the report's crease summary).
std::optional<CutFill> fandisk_slot_split(const std::vector<Vec3>& path, double radius,
                                          std::string_view plan) {
  auto cut = fill_slot_cut("fandisk.obj", path, radius);
  if (!cut) return cut;
  const HoleFillReport& r = cut->report.holes[0];
  EXPECT_EQ(r.method, FillMethod::CreaseSplit) << r.creases;
  EXPECT_EQ(r.creases, plan);
  return cut;
}

// A slot cut into fandisk along its curved top ridge up to the corner where the ridge meets two
// straight ones (the faces within 0.076 of the ridge's last 8 points, the crease-slot bench's
// seed 18 cut 1). The straight ridges leave the rim 0.10 from the corner and point at it; the
// curved one leaves 0.6 away, and its tangent line misses the corner by 0.11 (over twice the
// corner tolerance), so the three did not meet and the 3D triangulation spanned the slot (mean 2.7
// per mille, the ridges up to 9.3 off). Its bent crease, fitted along it at the rim, passes the
// corner: the single corner is found there (mean 0.03, the ridges within 0.23).
TEST(HoleCaseQuality, ThreeCreasesMeetWhereTheCurvedOneBendsIn) {
  const std::vector<Vec3> ridge{Vec3(4.3060, 14.3530, -0.9504), Vec3(4.3785, 14.3569, -0.9283),
                                Vec3(4.4518, 14.3602, -0.9096), Vec3(4.5260, 14.3629, -0.8942),
                                Vec3(4.6009, 14.3651, -0.8821), Vec3(4.6764, 14.3666, -0.8735),
                                Vec3(4.7520, 14.3675, -0.8683), Vec3(4.8279, 14.3678, -0.8666)};
  const auto cut =
      fandisk_slot_split(ridge, 0.076, "3 crease crossings, 3 curves meeting at a corner");
  ASSERT_TRUE(cut);
  const PatchDistances d = patch_distances(*cut);
  EXPECT_LE(d.mean, 0.5);
  EXPECT_LE(d.crease, 1.0);
}

// A slot along fandisk's curved top edge (radius 1.03) to its end, where it meets two straight
// edges at a corner of the symmetry plane (the faces within 0.0997 of 15 of its points,
// crease-slot bench seed 19 cut 7). The curved crease leaves the rim 1.4 from the corner and
// turns 75° on the way: continued as a parabola p + s·t + ½s²κ of its fitted bend it missed the
// corner by 0.26, so the three creases went unmatched and the 3D triangulation spanned the slot
// (mean 2.9 per mille, a 4.6° triangle). As its osculating circle it passes 0.02 from the corner
// (mean 0.55).
TEST(HoleCaseQuality, ACreaseThatTurnsFarMeetsItsCornerAlongItsCircle) {
  const std::vector<Vec3> edge{Vec3(1.21071, 13.9407, -2.45813),  Vec3(1.16039, 14.0236, -2.47273),
                               Vec3(1.10208, 14.1011, -2.48641),  Vec3(1.0365, 14.1726, -2.49901),
                               Vec3(0.963959, 14.2375, -2.51045), Vec3(0.885537, 14.295, -2.52059),
                               Vec3(0.801544, 14.3447, -2.52936), Vec3(0.712934, 14.3862, -2.53668),
                               Vec3(0.620725, 14.419, -2.54245),  Vec3(0.525907, 14.4425, -2.54661),
                               Vec3(0.429066, 14.4569, -2.54914), Vec3(0.3285, 14.4619, -2.55002),
                               Vec3(0.219, 14.4619, -2.55002),    Vec3(0.1095, 14.4619, -2.55002),
                               Vec3(0, 14.4619, -2.55002)};
  const auto cut =
      fandisk_slot_split(edge, 0.0996579402, "3 crease crossings, 3 curves meeting at a corner");
  ASSERT_TRUE(cut);
  const PatchDistances d = patch_distances(*cut);
  EXPECT_LE(d.mean, 0.6);
  // The corner lands 0.01 from the true one; the curved edge, a circle only near the rim, is
  // followed within 4.2 per mille.
  EXPECT_LE(d.crease, 4.5);
  EXPECT_GE(min_angle_deg(cut->mesh, cut->report.holes[0].new_faces), 15.0);
}

// A slot along fandisk's curved valley up to the corner where it meets two straight ridges (the
// faces within 0.141 of 10 points of the valley, crease-slot bench seed 17 cut 8): the three
// tangent lines meet, but outside the hole's projection, and the corner was refused (the 3D
// triangulation spanned the slot, mean 1.7 per mille, a 10.2° triangle). Their bent creases meet
// inside it (0.08).
TEST(HoleCaseQuality, ThreeCleanCreasesWhoseLinesMeetOutsideTheHoleMeetAlongTheirBends) {
  const std::vector<Vec3> valley{Vec3(4.7265, 15.2645, -0.5322), Vec3(4.6253, 15.2632, -0.5393),
                                 Vec3(4.5247, 15.2612, -0.5511), Vec3(4.4247, 15.2582, -0.5677),
                                 Vec3(4.3257, 15.2545, -0.5889), Vec3(4.2277, 15.2499, -0.6148),
                                 Vec3(4.1311, 15.2445, -0.6452), Vec3(4.0362, 15.2384, -0.6801),
                                 Vec3(3.9430, 15.2315, -0.7195), Vec3(3.8518, 15.2238, -0.7631)};
  const auto cut =
      fandisk_slot_split(valley, 0.141, "3 crease crossings, 3 curves meeting at a corner");
  ASSERT_TRUE(cut);
  EXPECT_LE(patch_distances(*cut).mean, 0.5);
  EXPECT_GE(min_angle_deg(cut->mesh, cut->report.holes[0].new_faces), 15.0);
}

// A slot along fandisk's curved valley (the faces within 0.135 of 18 of its points, the
// crease-slot bench's seed 9 cut 4) that ends where the valley meets a ridge inside the slot:
// two crossings, a concave 90° one and a convex 56° one, which no pair joins (a crease does not
// turn from valley to ridge) and which are too few for a corner of three. The 3D triangulation
// spanned the slot (mean 2.9 per mille, the creases up to 14.9 off). Their bent creases meet
// inside the hole: a corner of two creases (mean 0.27, the creases within 2.7).
TEST(HoleCaseQuality, TwoCleanCreasesLeftOverMeetAtACornerOfTheirOwn) {
  const std::vector<Vec3> valley{Vec3(4.0847, 15.6253, -0.2713), Vec3(3.9949, 15.6202, -0.3000),
                                 Vec3(3.9063, 15.6146, -0.3319), Vec3(3.8191, 15.6084, -0.3669),
                                 Vec3(3.7332, 15.6017, -0.4051), Vec3(3.6488, 15.5944, -0.4464),
                                 Vec3(3.5660, 15.5866, -0.4907), Vec3(3.4848, 15.5782, -0.5380),
                                 Vec3(3.4055, 15.5694, -0.5883), Vec3(3.3282, 15.5600, -0.6413),
                                 Vec3(3.2530, 15.5502, -0.6971), Vec3(3.1798, 15.5399, -0.7556),
                                 Vec3(3.1088, 15.5291, -0.8168), Vec3(3.0402, 15.5178, -0.8805),
                                 Vec3(2.9741, 15.5062, -0.9466), Vec3(2.9106, 15.4942, -1.0149),
                                 Vec3(2.8495, 15.4817, -1.0857), Vec3(2.7909, 15.4688, -1.1589)};
  const auto cut =
      fandisk_slot_split(valley, 0.135, "2 crease crossings, 2 curves meeting at a corner");
  ASSERT_TRUE(cut);
  const PatchDistances d = patch_distances(*cut);
  EXPECT_LE(d.mean, 0.5);
  EXPECT_LE(d.crease, 3.0);
}

// A slot round the end of fandisk's tongue, along the U-shaped edge of its flat top (the faces
// within 0.102 of nine of its points, the crease-slot bench's seed 5 cut 6). Two creases cross
// the rim, one heading straight in, the other round the bend, 74° off the chord between them:
// past the loose pairing's 65°, and they meet at no corner, so they were left unpaired and the 3D
// triangulation cut across the bend (mean 1.92 per mille, the crease 10.4 off, 3.9° slivers).
// Both bound the top face, so they are one crease: paired along the face's plane.
TEST(HoleCaseQuality, TwoCreasesBoundingOneFaceArePairedRoundItsBend) {
  const std::vector<Vec3> edge{
      Vec3(1.3285, 13.5792, 0),  Vec3(1.3285, 13.4733, 0),  Vec3(1.3285, 13.3675, 0),
      Vec3(1.3285, 13.2617, 0),  Vec3(1.3285, 13.1558, 0),  Vec3(1.3285, 13.05, 0),
      Vec3(1.34748, 12.9545, 0), Vec3(1.40143, 12.8735, 0), Vec3(1.48195, 12.8194, 0)};
  const auto cut = fandisk_slot_split(edge, 0.101587154, "2 crease crossings, 1 curve");
  ASSERT_TRUE(cut);
  EXPECT_GE(min_angle_deg(cut->mesh, cut->report.holes[0].new_faces), 15.0);
  const PatchDistances d = patch_distances(*cut);
  EXPECT_LE(d.mean, 0.5);    // 0.25 measured
  EXPECT_LE(d.crease, 2.0);  // 0.76 measured
}

// A ball cut out of fandisk at its end face (the faces within 0.642 of a point; the ball-cut
// bench's seed 2 cut 4 takes it with two more balls that leave this hole alone). Three creases
// cross the rim: two are one straight edge of the end face, paired; the third, a 43° ridge, runs
// into that edge inside the hole, where three faces meet. Left over, it was filled across (mean
// 1.58 per mille, 15.7°). It ends on the pair's curve, at a corner that splits that curve in
// two: 0.08 per mille, 21.3°.
TEST(HoleCaseQuality, ACreaseLeftOverEndsWhereItRunsIntoAPairedCurve) {
  const auto cut = fill_one_cut("fandisk.obj", Vec3(0.397441, 15.3644, -1.47466), 0.642317439);
  ASSERT_TRUE(cut);
  EXPECT_EQ(expect_crease_split_fill(*cut, 0.3).creases,
            "3 crease crossings, 3 curves meeting at a corner");
}

// A ball cut out of fandisk across its top edge by the tongue's root (the faces within 0.659 of
// a point; the ball-cut bench's seed 11 cut 7 takes it with two more balls that leave this hole
// alone). The edge crosses the rim once; where it leaves the hole it reaches the rim at a vertex
// with no sharp edge of its own and runs along one rim edge to the root's corner. Unmatched, the
// 3D triangulation folded across it (3.9°). The edge now ends where it reaches the rim: one
// straight curve, 20.6°.
TEST(HoleCaseQuality, ACreaseThatRunsAlongTheRimToItsCornerEndsWhereItReachesTheRim) {
  const auto cut = fill_one_cut("fandisk.obj", Vec3(3.11057, 13.6048, 0), 0.658811786);
  ASSERT_TRUE(cut);
  EXPECT_EQ(expect_crease_split_fill(*cut, 0.6).creases, "2 crease crossings, 1 curve");
}

//! A slot fill along the part's creases into a corner that follows them: every triangle 15° or
//! better, within 0.1 per mille of the removed faces on average, the creases within 1 per mille.
void expect_exact_corner_fill(const CutFill& cut) {
  EXPECT_GE(min_angle_deg(cut.mesh, cut.report.holes[0].new_faces), 15.0);
  const PatchDistances d = patch_distances(cut);
  EXPECT_LE(d.mean, 0.1);
  EXPECT_LE(d.crease, 1.0);
}

// A slot along fandisk's straight top edge up to the part's corner at x = 0 (the faces within
// 0.099 of three of its points, the crease-slot bench's seed 9 cut 7): the cut goes through the
// corner, whose vertex stays on the rim, and the three creases' corner falls 0.0002 from it, just
// inside the hole. The curves to that point bounded needles (0.11°). The creases end at the rim
// vertex instead: two curves, no corner.
TEST(HoleCaseQuality, ACornerOnTheRimEndsTheCreasesAtItsVertex) {
  const std::vector<Vec3> edge{Vec3(0.096389, 15.2005, -2.68026), Vec3(0.192779, 15.2005, -2.68026),
                               Vec3(0.289168, 15.2005, -2.68026)};
  const auto cut = fandisk_slot_split(edge, 0.0991162697, "3 crease crossings, 2 curves");
  ASSERT_TRUE(cut);
  expect_exact_corner_fill(*cut);
}

// A slot along fandisk's edge on its symmetry plane (the faces within 0.127 of four of its
// points, the crease-slot bench's seed 1 cut 9) that takes in two corners of the part joined by
// an edge, one of them left on the rim: four creases, meeting at two corners. The rim one lay
// 0.000014 from a crossing's vertex, and that split could not be linked into the mesh (the 3D
// triangulation spanned the slot: mean 2.90 per mille, the creases up to 11.4 off). With the
// corner at the rim vertex, the link to the other corner leaves from there: one corner inside,
// four curves.
TEST(HoleCaseQuality, OfTwoCornersTheOneOnTheRimIsItsVertex) {
  const std::vector<Vec3> edge{Vec3(4.8279, 15.5888, -0.478353), Vec3(4.8279, 15.6073, -0.373101),
                               Vec3(4.8279, 15.6259, -0.26785), Vec3(4.8279, 15.6444, -0.162599)};
  const auto cut =
      fandisk_slot_split(edge, 0.126976058, "4 crease crossings, 4 curves meeting at a corner");
  ASSERT_TRUE(cut);
  expect_exact_corner_fill(*cut);
}

// A slot along the start of the rim of couplingdown's small boss (the faces within 0.0157 of
// its first 4 points, as the crease-slot bench's seed 14 cut 2 takes them). Two creases of the
// boss run along rim edges: a pair's curve joined two neighbouring rim vertices, sampled a hair
// off their edge (0.0004 off a 0.041 edge), and the region between the curve and the edge was a
// 3.2° sliver with both its sides fixed. Such a curve is the edge: 15° or better.
TEST(HoleCaseQuality, ACreaseAlongARimEdgeLeavesNoSliver) {
  const std::vector<Vec3> rim{
      Vec3(0.00600464, -0.384173, 0.157233), Vec3(0.0172957, -0.388282, 0.157233),
      Vec3(0.0264971, -0.396003, 0.157233), Vec3(0.0325052, -0.406409, 0.157233)};
  const auto cut = fill_slot_cut("couplingdown.off", rim, 0.0156543486);
  ASSERT_TRUE(cut);
  expect_crease_split_fill(*cut, 0.05);
}

// A slot along fandisk's curved valley down to the part's corner where it meets two straight
// edges (the faces within 0.113 of 10 of its points, the crease-slot bench's seed 8 cut 9). The
// curved crease misses the corner along its tangent line, so the corner is where the bent
// creases come closest; one straight edge is traced over 2 edges only before it reaches the
// part's next corner, too few to fit a bend, and the run was refused: the 3D triangulation
// spanned the slot (mean 2.3 per mille, a 2.1° triangle). A crease too short for a bend goes
// straight on along its tangent when another crease's bend is fitted.
TEST(HoleCaseQuality, AShortStraightCreaseMeetsACurvedOneAtTheirCorner) {
  const std::vector<Vec3> valley{Vec3(2.89124, 15.0488, -1.75557), Vec3(2.85126, 15.0326, -1.84753),
                                 Vec3(2.81586, 15.0161, -1.94106), Vec3(2.78505, 14.9993, -2.03602),
                                 Vec3(2.75882, 14.9823, -2.13252), Vec3(2.7373, 14.9651, -2.23),
                                 Vec3(2.72056, 14.9478, -2.32814), Vec3(2.70854, 14.9304, -2.4271),
                                 Vec3(2.70132, 14.9129, -2.52645), Vec3(2.6989, 14.8952, -2.62643)};
  const auto cut =
      fandisk_slot_split(valley, 0.112777271, "3 crease crossings, 3 curves meeting at a corner");
  ASSERT_TRUE(cut);
  expect_exact_corner_fill(*cut);
}

// A slot along fandisk's curved top edge to the part's corner on its symmetry plane (the faces
// within 0.071 of 10 of its points, the crease-slot bench's seed 5 cut 8). The corner's vertex
// stays on the rim with no sharp edge left outside the hole, so no crossing is there; the three
// creases' corner fell 0.0012 from it, and the curves to it bounded 0.46° needles. The creases
// end at that rim vertex (it gets a crossing of its own).
TEST(HoleCaseQuality, ACornerAtARimVertexWithNoCrossingEndsTheCreasesThere) {
  const std::vector<Vec3> edge{Vec3(3.94577, 15.537, -0.772045),  Vec3(4.03863, 15.5439, -0.733004),
                               Vec3(4.13326, 15.55, -0.698344),   Vec3(4.22945, 15.5553, -0.66814),
                               Vec3(4.32697, 15.5598, -0.642467), Vec3(4.42563, 15.5635, -0.621371),
                               Vec3(4.52517, 15.5665, -0.604909), Vec3(4.62494, 15.5685, -0.593153),
                               Vec3(4.7256, 15.5698, -0.586026),  Vec3(4.8279, 15.5702, -0.583604)};
  const auto cut = fandisk_slot_split(edge, 0.0712293537, "4 crease crossings, 3 curves");
  ASSERT_TRUE(cut);
  expect_exact_corner_fill(*cut);
}

// A ball cut into fandisk across the end of its side plane (ball-cut bench seed 4 cut 0): six
// creases cross the hole and meet at corners in a row on the side plane (four since
// join_at_four_corners: the step's ridge and valley each end at one of their own; three before,
// 1.25 per mille mean, now 0.80). The last corner is one of three faces (the side plane and two
// curved ones) and its link runs along the edge of the side plane and the upper curved face.
// That link was taken from the rim triangles just outside the corner's creases, but the one
// after the side plane's crease still belongs to the lower curved face (it reaches past the
// crease's rim vertex): the link pointed across the part, the next corner was refused as lying
// behind it, and the 3D triangulation spanned the hole (17.3 per mille mean). From the creases'
// own faces the link runs up the side plane.
TEST(HoleCaseQuality, ACornerLinkLeavesAlongTheFacesOfItsCreases) {
  const auto cut = fill_one_cut("fandisk.obj", Vec3(4.53432, 13.9805, -0.328044), 1.00622902);
  ASSERT_TRUE(cut);
  const HoleFillReport& r = expect_crease_split_fill(*cut, 1.5);
  EXPECT_EQ(r.creases, "6 crease crossings, 9 curves meeting at 4 corners");
}

// A ball cut into fandisk across the end of its step, where the step meets the side plane
// (ball-cut bench seed 11 cut 2, its largest ball): six creases cross the hole and meet at four
// corners in a row on the side plane, P - Q - R - S. P and S take two creases each (the top
// plane's two edges at P, the side plane's lower edge and a ridge of the step at S); Q and R one
// each (the step's ridge and valley), joined to P, to S and to each other by the side plane's
// edges. With three corners at most the plan found none, every crease went unmatched and the
// 3D triangulation spanned the hole (mean 21.8 per mille, Hausdorff 56, a 1.8° triangle).
TEST(HoleCaseQuality, AStepEndingAtASidePlaneMeetsItAtFourCorners) {
  const auto cut = fill_one_cut("fandisk.obj", Vec3(4.24637, 13.8764, -0.371368), 1.12559913);
  ASSERT_TRUE(cut);
  const HoleFillReport& r = expect_crease_split_fill(*cut, 0.5);
  EXPECT_EQ(r.creases, "6 crease crossings, 9 curves meeting at 4 corners");
  EXPECT_LE(patch_distances(*cut).crease, 3.0);
}

// A ball cut into fandisk whose rim follows a ridge for five edges (ball-cut bench seed 10 cut
// 5): the ridge's crossings at both ends of that stretch were paired, and their curve ran
// alongside the rim, a hair off it, leaving slivers (0.086°) that no pass can mend; the split
// was refused, and so was its retry, and the 3D triangulation spanned the hole (mean 11.8 per
// mille, a 1.6° triangle). A curve that hugs the rim over several edges is that stretch of the
// rim, as one along a single edge is that edge.
TEST(HoleCaseQuality, ACreaseTheRimFollowsForSeveralEdgesIsTheRim) {
  const auto cut = fill_one_cut("fandisk.obj", Vec3(2.42791, 13.288, -1.719), 0.981917465);
  ASSERT_TRUE(cut);
  expect_crease_split_fill(*cut, 3.0);
}

// A ball cut that takes the whole tip of fandisk's thin wing (ball-cut bench, seed 1 cut 0): the
// hole is a belt around the wing, over its top, its bottom and its two sides, and the tip's two
// corners (top and bottom, joined by its vertical edge) stick out of the belt, 1.15 from the
// rim's centroid against a rim radius of 0.91. The corners were looked for only within the rim's
// ball: the four creases went unmatched and the 3D triangulation spanned the tip (mean 8.1‰,
// Hausdorff 37‰, a 2.2° triangle).
TEST(HoleCaseQuality, ATipCutOffAWingGetsItsCornersBack) {
  const auto cut = fill_one_cut("fandisk.obj", Vec3(4.09566, 17.7708, -0.247743), 0.947883214);
  ASSERT_TRUE(cut);
  ASSERT_EQ(cut->report.holes.size(), 1u);
  const HoleFillReport& r = cut->report.holes[0];
  ASSERT_TRUE(r.filled) << r.reason;
  EXPECT_EQ(r.method, FillMethod::CreaseSplit) << r.creases;
  EXPECT_NE(r.creases.find("at 2 corners"), std::string::npos) << r.creases;
  EXPECT_GE(min_angle_deg(cut->mesh, r.new_faces), 15.0);
  const PatchDistances d = patch_distances(*cut);
  EXPECT_LE(d.mean, 2.0);
  EXPECT_LE(d.crease, 3.0);
}

//! \p soup without the faces whose centroid lies inside any of \p balls (centre, radius): the
//! ball-cut bench's cuts (`touchmend-cut-bench --only MESH:SEED:CUT` prints a cut's balls).
MeshSoup cut_out_balls(const MeshSoup& soup, const std::vector<std::pair<Vec3, double>>& balls) {
  return testing::remove_faces(soup, [&](const Vec3& c) {
    return std::any_of(balls.begin(), balls.end(),
                       [&](const auto& b) { return (c - b.first).norm() < b.second; });
  });
}

//! For each shared mesh, \p trials cuts: the faces within a random radius (1% to \p max_radius
//! of the diagonal) of a random vertex removed; \p visit(holed soup, trial) under a trace that
//! names the mesh and trial.
//! \p max_balls > 1: each cut removes the faces within one to \p max_balls random balls (the
//! holes they leave merge, pinch and leave islands).
template <typename Visit>
void for_each_random_cut(std::mt19937& random, int trials, double max_radius, Visit&& visit,
                         int max_balls = 1) {
  for (const char* name : {"couplingdown.off", "fandisk.obj", "hand.off", "mech-holes-shark.off",
                           "rocker-arm.obj", "sphere966.off", "spot.obj"}) {
    const auto read = read_mesh_file(testing::shared_data_dir() + "/meshes/" + name);
    ASSERT_TRUE(read.ok) << read.error;
    Box3 box;
    for (const Vec3& p : read.soup.points) box.extend(Eigen::Vector3d(p[0], p[1], p[2]));
    const double diagonal = box.diagonal().norm();
    for (int trial = 0; trial < trials; ++trial) {
      const int balls =
          max_balls > 1 ? std::uniform_int_distribution<int>(1, max_balls)(random) : 1;
      std::vector<std::pair<Vec3, double>> cut;
      for (int b = 0; b < balls; ++b) {
        const Vec3 centre = read.soup.points[std::uniform_int_distribution<std::size_t>(
            0, read.soup.points.size() - 1)(random)];
        const double radius =
            diagonal * std::uniform_real_distribution<double>(0.01, max_radius)(random);
        cut.emplace_back(centre, radius);
      }
      SCOPED_TRACE(std::string(name) + " trial " + std::to_string(trial));
      MeshSoup holed = cut_out_balls(read.soup, cut);
      visit(holed, trial);
    }
  }
}

//! Fills every hole of \p holed with the defaults and checks the invariants of every fill.
FillReport fill_all_checked(const MeshSoup& holed) {
  Mesh mesh = build_mesh(holed).mesh;
  const auto holes = find_holes(mesh).holes;
  const testing::Snapshot before = testing::take_snapshot(mesh);
  FillReport report = fill_holes(mesh, {}, {});
  const std::string problems = testing::check_fill_invariants(before, mesh, report.holes, holes);
  EXPECT_TRUE(problems.empty()) << problems;
  return report;
}

//! The ball cut \p balls of shared mesh \p mesh_name filled whole with the defaults
//! (fill_all_checked: the invariants kept), every hole closed: the report of its one hole with
//! \p boundary edges (none, with a failure, if there is not exactly one).
std::optional<HoleFillReport> fill_ball_cut(const std::string& mesh_name,
                                            const std::vector<std::pair<Vec3, double>>& balls,
                                            std::size_t boundary) {
  const auto read = read_mesh_file(testing::shared_data_dir() + "/meshes/" + mesh_name);
  EXPECT_TRUE(read.ok) << read.error;
  if (!read.ok) return std::nullopt;
  std::vector<HoleFillReport> matching;
  for (HoleFillReport& r : fill_all_checked(cut_out_balls(read.soup, balls)).holes) {
    EXPECT_TRUE(r.filled) << "hole " << r.hole_id << ": " << r.reason;
    if (r.boundary_vertices == boundary) matching.push_back(std::move(r));
  }
  EXPECT_EQ(matching.size(), 1u) << "holes with " << boundary << " boundary edges";
  if (matching.size() != 1) return std::nullopt;
  return std::move(matching.front());
}

// Holes no one picked: the faces within a random radius (1–8% of the diagonal) of a random
// vertex removed from each shared mesh, eight times each, and every hole filled with the
// defaults. Whatever the cut leaves (several loops, narrow rim corners, creases at odd angles),
// every fill keeps the invariants (closed, manifold, consistently oriented, no intersection,
// nothing else changed) and almost every hole is closed.
TEST(HoleCasesRandom, RandomHolesCutIntoEveryMeshAreFilledCleanly) {
  std::mt19937 random(7);
  std::size_t fills = 0, closed = 0;
  for_each_random_cut(random, 8, 0.08, [&](MeshSoup& holed, int) {
    for (const HoleFillReport& r : fill_all_checked(holed).holes) {
      ++fills;
      closed += r.filled ? 1 : 0;
      EXPECT_TRUE(r.filled || !r.reason.empty());  // an open hole says why
    }
  });
  EXPECT_GE(fills, 56u);
  EXPECT_GE(closed, fills * 95 / 100);
}

// Cuts of one to five overlapping balls: the holes merge, and where an island of faces is left
// touching the rim at one vertex the loop passes that vertex twice (a pinched hole). Every fill
// keeps the invariants; pinched holes are closed across the pinch and filled like the rest.
TEST(HoleCasesRandom, HolesCutByOverlappingBallsIncludingPinchedOnesAreFilledCleanly) {
  std::mt19937 random(4);
  std::size_t fills = 0, closed = 0, pinched = 0, pinched_closed = 0;
  for_each_random_cut(
      random, 8, 0.15,
      [&](MeshSoup& holed, int) {
        for (const HoleFillReport& r : fill_all_checked(holed).holes) {
          const bool pinch = (r.filled && !r.warnings.empty() &&
                              r.warnings[0].find("pinched") != std::string::npos) ||
                             r.reason.find("pinched") != std::string::npos;
          ++(pinch ? pinched : fills);
          (pinch ? pinched_closed : closed) += r.filled ? 1 : 0;
          EXPECT_TRUE(r.filled || !r.reason.empty());  // an open hole says why
        }
      },
      5);
  EXPECT_GE(fills, 150u);
  EXPECT_GE(closed, fills * 95 / 100);
  // Measured (seed 4): 207 of 208 holes closed, 9 of 9 pinched ones.
  EXPECT_GE(pinched, 6u);
  EXPECT_GE(pinched_closed, pinched * 3 / 4);
}

// Five balls cut out of mech-holes-shark (ball-cut bench, seed 8 cut 6) leave a 128-edge hole
// merged with one of the part's own openings, whose rim folds over its span: every round of the
// avoiding 3D triangulation forbade the one or two triangles that crossed the mesh, the next
// solution crossed beside them, and after its budget the hole was left open (every other
// method crossed too). The last resort tests the fans of the short edges beside the crossing
// triangles whole: the hole is closed.
TEST(HoleCasesRandom, AHoleWhoseAvoidingRoundsRunOutIsClosedByForbiddingFans) {
  const std::vector<std::pair<Vec3, double>> balls{
      {Vec3(0.258078992, 0.498602986, -0.345764011), 0.23072732},
      {Vec3(0.390560001, 0.111491002, 0.188259005), 0.119129412},
      {Vec3(0.315634996, 0.499570012, 0.258271992), 0.121827576},
      {Vec3(0.387638986, 0.0771713033, 0.485065013), 0.179820579},
      {Vec3(0.319759995, 0.145512, -0.0574042015), 0.181554073}};
  const std::optional<HoleFillReport> r = fill_ball_cut("mech-holes-shark.off", balls, 128);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->method, FillMethod::MinimumWeight3d);
}

// Four balls cut out of hand (the ball-cut bench's seed 1, cut 7) leave a 13-edge hole whose
// faired patches have no vertex to fair: the flat stand-in is the planar triangulation, 14.9°
// at its worst, and its mending (bisections across the bent rim, which the smoothing could
// not mend) took it to 5.5°. The unmended build is kept when its smallest angle is the larger.
TEST(HoleCasesRandom, AFlatPatchWhoseMendingEndsWorseIsKeptUnmended) {
  const std::vector<std::pair<Vec3, double>> balls{
      {Vec3(-0.0960384, 0.194568, 0.365899), 0.0742741242},
      {Vec3(-0.425191, 0.0438089, 0.0271768), 0.112256384},
      {Vec3(0.139733, -0.0591163, 0.128504), 0.0774225682},
      {Vec3(0.0534142, -0.0542121, 0.125417), 0.0526210759}};
  const std::optional<HoleFillReport> r = fill_ball_cut("hand.off", balls, 13);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->shape, PatchShape::Flat);
  EXPECT_GE(r->min_angle_deg, 14.5);  // 5.5° mended
  EXPECT_NE(r->shape_reason.find("not mended (mended, its smallest angle was"), std::string::npos)
      << r->shape_reason;
}

// Three balls cut out of spot (the ball-cut bench's seed 8, cut 1) leave a 66-edge hole split
// along one crease curve and faired. The mending before the fairing bisected where fairing then
// pulled a new vertex against the rim: 9.1° at the end. Mended without those bisections the
// faired patch keeps 18.8° (its distance to the removed faces the same, 2.81 per mille).
TEST(HoleCasesRandom, AFairedPatchUnder15DegreesIsTriedWithoutBisectionsBeforeFairing) {
  const std::vector<std::pair<Vec3, double>> balls{
      {Vec3(0.240602, -0.341214, -0.117452), 0.0566588695},
      {Vec3(-0.024587, -0.350255, -0.0669927), 0.320043683},
      {Vec3(0.289863, 0.0225221, 0.77107), 0.217379305}};
  const std::optional<HoleFillReport> r = fill_ball_cut("spot.obj", balls, 66);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->method, FillMethod::CreaseSplit);
  EXPECT_EQ(r->shape, PatchShape::Fair);
  EXPECT_GE(r->min_angle_deg, 15.0);  // 9.1° with the bisections
  EXPECT_NE(r->shape_reason.find("mended without bisections before fairing"), std::string::npos)
      << r->shape_reason;
}

// Two balls cut out of couplingdown (the ball-cut bench's seed 2, cut 8) leave an 18-edge hole
// whose thin plate is refused (nothing to fair); its flat stand-in ends at 8.0° and is set aside
// for a membrane, which is refused too. The stand-in then comes back exactly as it was built
// and checked, not built again: the fill is the one made with no membrane to try, vertex for
// vertex and face for face.
TEST(HoleCasesRandom, APatchSetAsideForARivalThatDoesNoBetterComesBackAsItWas) {
  const auto read = read_mesh_file(testing::shared_data_dir() + "/meshes/couplingdown.off");
  ASSERT_TRUE(read.ok) << read.error;
  const std::vector<std::pair<Vec3, double>> balls{
      {Vec3(0.17123, -0.137008, 0.0572529), 0.0600358918},
      {Vec3(0.163898, -0.0524814, -0.0330189), 0.0413462461}};
  const MeshSoup holed = cut_out_balls(read.soup, balls);
  const auto fill_the_hole = [&](const FillOptions& options, Mesh& mesh) {
    mesh = build_mesh(holed).mesh;
    const auto holes = find_holes(mesh).holes;
    const auto hole =
        std::find_if(holes.begin(), holes.end(), [](const Hole& h) { return h.loop.size() == 18; });
    EXPECT_NE(hole, holes.end());
    const testing::Snapshot before = testing::take_snapshot(mesh);
    HoleFillReport r = hole == holes.end() ? HoleFillReport{} : fill_hole(mesh, *hole, options);
    EXPECT_TRUE(testing::check_fill_invariants(before, mesh, {r}, holes).empty());
    return r;
  };
  Mesh with_rival, without;
  const HoleFillReport r = fill_the_hole(FillOptions{}, with_rival);
  ASSERT_TRUE(r.filled) << r.reason;
  EXPECT_EQ(r.shape, PatchShape::Flat);
  ASSERT_FALSE(r.warnings.empty());
  EXPECT_NE(r.warnings.front().find("(a membrane)"), std::string::npos) << r.warnings.front();
  EXPECT_LT(r.min_angle_deg, 15.0);
  FillOptions no_membrane;
  no_membrane.membrane_fallback = false;
  const HoleFillReport alone = fill_the_hole(no_membrane, without);
  ASSERT_TRUE(alone.filled) << alone.reason;
  ASSERT_EQ(r.new_vertices.size(), alone.new_vertices.size());
  ASSERT_FALSE(r.new_vertices.empty());
  for (std::size_t i = 0; i < r.new_vertices.size(); ++i)
    EXPECT_EQ(with_rival.point(r.new_vertices[i]), without.point(alone.new_vertices[i]));
  const auto corners = [](const Mesh& mesh, const std::vector<FaceHandle>& faces) {
    std::multiset<std::array<double, 9>> out;
    for (const FaceHandle f : faces) {
      std::array<double, 9> c{};
      int k = 0;
      for (const VertexHandle v : mesh.fv_range(f))
        for (int d = 0; d < 3; ++d) c[static_cast<std::size_t>(k++)] = mesh.point(v)[d];
      out.insert(c);
    }
    return out;
  };
  EXPECT_EQ(corners(with_rival, r.new_faces), corners(without, alone.new_faces));
  EXPECT_EQ(r.min_angle_deg, alone.min_angle_deg);
}

// Five balls cut out of fandisk (the ball-cut bench's seed 10, cut 6) leave a 132-edge hole with
// ten crease crossings: two pairs and six creases that meet at two corners, one of them past
// the rim's ball (a wing's tip). The split along all nine curves crosses the mesh, and so does
// the one without the pair nearest that crossing; leaving the corners out then brings back
// that pair too (it was not what crossed): the split along both pairs holds. Before, the pair
// stayed out and the fill kept one curve (mean 10.9 against 6.9 per mille).
TEST(HoleCasesRandom, LeavingTheCornersOutBringsBackThePairsLeftOutBefore) {
  const std::vector<std::pair<Vec3, double>> balls{{Vec3(2.63484, 13.3857, -1.13945), 1.00602513},
                                                   {Vec3(2.4279, 13.1525, -0.60166), 0.292172719},
                                                   {Vec3(4.3351, 16.1745, 0), 0.268886248},
                                                   {Vec3(4.8279, 15.231, -0.721811), 1.05108287},
                                                   {Vec3(4.16427, 14.8512, -1.09415), 0.884612993}};
  const std::optional<HoleFillReport> r = fill_ball_cut("fandisk.obj", balls, 132);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->method, FillMethod::CreaseSplit) << r->shape_reason;
  EXPECT_NE(r->shape_reason.find("split along 2 crease curves"), std::string::npos)
      << r->shape_reason;
}

// A slot along the rim of couplingdown's top boss where it meets a small tooth (the faces within
// 0.0229 of 6 points of the rim, crease-slot bench seed 14 cut 7): eight creases cross the
// hole, and the plan joins two pairs and the tooth's short creases at a corner, one of the
// tooth's corners lying on the rim (its creases end at that rim vertex). That split cannot be
// linked into the mesh; the retry with half its curves can (before the split took a curve that
// hugs a stretch of the rim for the rim, that one crossed the mesh too, and a further retry
// along the two pairs closed the slot). Without the retries the 3D triangulation spans the slot
// (mean 0.69 per mille against 0.003).
TEST(HoleCaseQuality, ACreaseSplitRetryKeepsThePairsWhereTheToothCannotBeSplit) {
  const std::vector<Vec3> rim{
      Vec3(-0.087889, 0.357273, 0.157233),   Vec3(-0.0478455, 0.3648, 0.157233),
      Vec3(-0.00721597, 0.367854, 0.157233), Vec3(0.0335014, 0.366396, 0.157233),
      Vec3(0.073807, 0.360445, 0.157233),    Vec3(0.113208, 0.350075, 0.157233)};
  const auto cut = fill_slot_cut("couplingdown.off", rim, 0.0228578826);
  ASSERT_TRUE(cut);
  const HoleFillReport& r = cut->report.holes[0];
  EXPECT_EQ(r.method, FillMethod::CreaseSplit) << r.creases;
  EXPECT_EQ(r.creases, "8 crease crossings, 3 curves, 2 unmatched");
  EXPECT_LE(patch_distances(*cut).mean, 0.05);
}

// Four balls cut out of sphere966 (one of the overlapping-ball cuts, seed 1) leave a hole
// pinched at one vertex. The triangle that closes the pinch, chosen before the patch exists,
// was a 12.0° sliver beside the patch; flipping its edge across the patch once the disk is
// filled makes it 22.6°.
TEST(HoleCasesRandom, PinchClosingTriangleIsFlippedIntoThePatch) {
  const auto read = read_mesh_file(testing::shared_data_dir() + "/meshes/sphere966.off");
  ASSERT_TRUE(read.ok) << read.error;
  const std::vector<std::pair<Vec3, double>> balls{
      {Vec3(-1.1703600000000001, 2.5627300000000002, 9.5949299999999997), 5.0329924370324521},
      {Vec3(-6.2833399999999999, 1.8449500000000001, -7.5575000000000001), 1.8097314025801328},
      {Vec3(5.1874099999999999, -8.0717700000000008, 2.8173300000000001), 0.58180628145318991},
      {Vec3(0, -6.54861, 7.5575000000000001), 4.0038659545391253}};
  const MeshSoup holed = cut_out_balls(read.soup, balls);
  Mesh mesh = build_mesh(holed).mesh;
  const auto holes = find_holes(mesh).holes;
  const testing::Snapshot before = testing::take_snapshot(mesh);
  const FillReport report = fill_holes(mesh, {}, {});
  const std::string problems = testing::check_fill_invariants(before, mesh, report.holes, holes);
  EXPECT_TRUE(problems.empty()) << problems;
  std::size_t pinched = 0;
  for (const HoleFillReport& r : report.holes) {
    if (r.warnings.empty() || r.warnings[0].find("pinched") == std::string::npos) continue;
    ++pinched;
    ASSERT_TRUE(r.filled);
    // The closing triangle comes first among the new faces.
    EXPECT_GE(min_angle_deg(mesh, {r.new_faces.front()}), 15.0);
  }
  EXPECT_EQ(pinched, 1u);
}

// A couplingdown cut whose centre vertex stays on the rim, moved to a tenth of its distance
// from the next rim vertex (a damaged rim, as RandomHolesWithDamagedRimsAreFilledOrLeftOpenCleanly
// makes them; found with another seed of it). The crease split drew its curve alongside the
// new 0.005-long rim edge and the next one and left triangles of 0.003°; the patch was refused
// for them and the 3D triangulation closed the hole (2.6°). A curve that hugs a stretch of the
// rim is that stretch: the split makes the same fill, with no degenerate patch on the way.
TEST(HoleCasesRandom, ACreaseAlongADamagedRimLeavesNoDegenerateTriangle) {
  const Vec3 centre(-0.30123800000000001, -0.38917299999999999, 0.15723300000000001);
  bool moved = false;
  const auto cut =
      fill_one_cut("couplingdown.off", centre, 0.031055353897221093, [&](MeshSoup& holed) {
        const Mesh mesh = build_mesh(holed).mesh;
        for (const Hole& hole : find_holes(mesh).holes)
          for (std::size_t i = 0; i < hole.loop.size(); ++i) {
            Vec3& p = holed.points[static_cast<std::size_t>(hole.loop[i].idx())];
            if (p != centre) continue;
            const Vec3 next = mesh.point(hole.loop[(i + 1) % hole.loop.size()]);
            p = next + 0.1 * (p - next);
            moved = true;
          }
      });
  ASSERT_TRUE(moved);
  ASSERT_TRUE(cut);
  const HoleFillReport& r = cut->report.holes[0];
  EXPECT_EQ(r.method, FillMethod::CreaseSplit) << r.creases;
  EXPECT_GE(r.min_angle_deg, kDegenerateAngleDeg);
  for (const auto& w : r.warnings) EXPECT_EQ(w.find("degenerate"), std::string::npos) << w;
}

// How a rim is damaged in RandomHolesWithDamagedRimsAreFilledOrLeftOpenCleanly.
enum class RimDamage {
  Jitter,         //!< moved by up to 30% of the mean rim edge along each axis
  NearDuplicate,  //!< moved to a tenth of its distance from its next rim neighbour
  Straight,       //!< moved onto the chord between its rim neighbours (a 180° rim corner)
  Pinch,          //!< moved 50-140% of the way to the hole's centroid (a rim that may fold over)
  NearStraight,   //!< onto that chord, then by up to 5% of the mean rim edge off it
};

//! Damages up to a quarter of the vertices of every hole's rim in \p soup (distinct, no two
//! adjacent). Straight rims are made only at vertices with two or more faces: at a vertex with
//! one face it would make that face degenerate, which the fill rightly does not build against.
void damage_rims(MeshSoup& soup, RimDamage damage, std::mt19937& random) {
  const Mesh mesh = build_mesh(soup).mesh;
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (const Hole& hole : find_holes(mesh).holes) {
    const std::size_t n = hole.loop.size();
    if (n < 4) continue;
    double mean_edge = 0;
    for (std::size_t i = 0; i < n; ++i)
      mean_edge += (mesh.point(hole.loop[i]) - mesh.point(hole.loop[(i + 1) % n])).norm();
    mean_edge /= static_cast<double>(n);
    std::vector<char> damaged(n, 0);
    const int count = std::uniform_int_distribution<int>(1, std::max<int>(1, n / 4))(random);
    for (int c = 0; c < count; ++c) {
      const std::size_t i = std::uniform_int_distribution<std::size_t>(0, n - 1)(random);
      if (damaged[i] || damaged[(i + 1) % n] || damaged[(i + n - 1) % n]) continue;
      damaged[i] = 1;
      const Vec3 prev = mesh.point(hole.loop[(i + n - 1) % n]),
                 next = mesh.point(hole.loop[(i + 1) % n]);
      Vec3& p = soup.points[static_cast<std::size_t>(hole.loop[i].idx())];
      const Vec3 wobble(unit(random), unit(random), unit(random));
      switch (damage) {
        case RimDamage::Jitter:
          p += 0.3 * mean_edge * wobble;
          break;
        case RimDamage::NearDuplicate:
          p = next + 0.1 * (p - next);
          break;
        case RimDamage::Straight:
          if (mesh.valence(hole.loop[i]) > 2) p = 0.5 * (prev + next);
          break;
        case RimDamage::Pinch:
          p += std::uniform_real_distribution<double>(0.5, 1.4)(random) * (hole.centroid - p);
          break;
        case RimDamage::NearStraight:
          p = 0.5 * (prev + next) + 0.05 * mean_edge * wobble;
          break;
      }
    }
  }
}

// Holes whose rims a scanner or an earlier edit left damaged: nearly coincident rim vertices,
// straight and nearly straight runs (180° rim corners), jittered and pinched rims that may fold
// over. Every hole is either filled with the invariants kept (no degenerate or intersecting
// triangle, manifold, nothing else changed) or left open with its reason. With this seed a
// mech-holes-shark hole had a 0.02° triangle before Liepa's centroid split left nearly
// straight rim caps alone (refinement.cpp; 2 of 12 seeds tried had such a hole, none now).
TEST(HoleCasesRandom, RandomHolesWithDamagedRimsAreFilledOrLeftOpenCleanly) {
  std::mt19937 random(11);
  std::size_t fills = 0, closed = 0, pinched = 0, pinched_closed = 0;
  for_each_random_cut(random, 20, 0.06, [&](MeshSoup& holed, int trial) {
    const auto damage = static_cast<RimDamage>(trial % 5);
    damage_rims(holed, damage, random);
    for (const HoleFillReport& r : fill_all_checked(holed).holes) {
      EXPECT_TRUE(r.filled || !r.reason.empty());  // an open hole says why
      const bool pinch = damage == RimDamage::Pinch;
      ++(pinch ? pinched : fills);
      (pinch ? pinched_closed : closed) += r.filled ? 1 : 0;
    }
  });
  // Jittered, near-duplicate and straight rims are almost always closed (96-99% over 12 seeds);
  // a pinched rim folds over in about half the cases, and its hole then cannot be closed
  // without crossing it (44-63% closed).
  EXPECT_GE(fills, 112u);  // at least one hole per trial
  EXPECT_GE(closed, fills * 90 / 100);
  EXPECT_GE(pinched_closed, pinched / 3);
}

// rocker-arm_xl's 264-vertex hole on a curved part: the first faired patch crosses the
// surrounding surface. Faired again with the crowded vertices collapsed before fairing, it no
// longer does, and the faired fill is closer to the ground truth than every anchor (all of
// which are either flat or intersect the mesh); a flat fill is farther.
TEST(HoleCasesShape, FairedPatchThatCrossesTheMeshIsFairedAgainWithCollapses) {
  std::string error;
  const auto c = testing::load_case("rocker-arm_xl", error);
  ASSERT_TRUE(c) << error;
  ASSERT_EQ(c->holes.size(), 1u);
  const auto baseline = testing::read_baseline();
  const auto anchor = baseline.find({c->name, "0"});
  ASSERT_NE(anchor, baseline.end());
  const auto fill = [&](const FillOptions& options) {
    Mesh mesh = build_mesh(c->holed).mesh;
    const auto holes = find_holes(mesh).holes;
    const testing::Snapshot before = testing::take_snapshot(mesh);
    const FillReport report = fill_holes(mesh, {}, options);
    EXPECT_EQ(report.holes.size(), 1u);
    const HoleFillReport& r = report.holes.at(0);
    EXPECT_TRUE(r.filled) << r.reason;
    const std::string problems = testing::check_fill_invariants(before, mesh, report.holes, holes);
    EXPECT_TRUE(problems.empty()) << problems;
    return std::pair{r, testing::score_fill(mesh, r, *c, c->holes.at(0))};
  };
  const auto [faired, faired_score] = fill({});
  EXPECT_EQ(faired.shape, PatchShape::Fair) << faired.shape_reason;
  bool retried = false, piecewise_tried = false;
  for (const auto& w : faired.warnings) {
    retried =
        retried || w.find("faired again with the crowded vertices collapsed") != std::string::npos;
    piecewise_tried = piecewise_tried || w.find("piecewise") != std::string::npos;
  }
  EXPECT_TRUE(retried);
  // The retry reuses the 3D triangulation and comes before the piecewise method's own.
  EXPECT_FALSE(piecewise_tried);
  EXPECT_LT(faired_score.mean_permille, anchor->second.best_mean);
  FillOptions flat;
  flat.shape = PatchShape::Flat;
  const auto [kept_flat, flat_score] = fill(flat);
  EXPECT_EQ(kept_flat.shape, PatchShape::Flat);
  EXPECT_LT(faired_score.mean_permille, flat_score.mean_permille);
}

}  // namespace
}  // namespace touchmend::geometry
