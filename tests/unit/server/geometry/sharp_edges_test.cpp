// Creases across holes with no device (sharp_edges.h): a hole cut across a cube's edge has two
// crossings joined by one curve, a hole at a cube's corner three crossings meeting at the
// corner; `SharpMode::Auto` fills them so that the true crease lies on the patch, and the
// result is closed, manifold and free of intersections. The region split itself is checked on
// a planar loop.

#include "server/geometry/sharp_edges.h"

#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <numbers>

#include <gtest/gtest.h>

#include "server/geometry/hole_filling.h"
#include "server/geometry/mesh_build.h"
#include "server/geometry/mesh_intersections.h"
#include "server/geometry/metrics.h"
#include "tests/support/invariants.h"
#include "tests/support/mesh_factory.h"

namespace touchmend::geometry {
namespace {

constexpr int kCube = 8;

//! The cube [0, 8]³ with the faces near \p centre removed (a hole across an edge or a corner).
Mesh cube_with_hole(const Vec3& centre, double radius) {
  return build_mesh(testing::cube_with_hole(kCube, centre, radius)).mesh;
}

double crease_distance(const Mesh& mesh, const HoleFillReport& fill,
                       const std::vector<std::array<Vec3, 2>>& crease) {
  const auto triangles = face_triangles(mesh, fill.new_faces);
  return segment_distance(crease, triangles, 0.01).max;
}

TEST(SharpEdges, HoleAcrossAnEdgeHasOneCurveAlongIt) {
  const Mesh mesh = cube_with_hole(Vec3(kCube, 4, kCube), 2.2);
  const auto holes = find_holes(mesh).holes;
  ASSERT_EQ(holes.size(), 1u);
  const HoleCreasePlan plan = plan_hole_creases(mesh, holes[0]);
  ASSERT_EQ(plan.crossings.size(), 2u) << plan.summary;
  ASSERT_EQ(plan.curves.size(), 1u) << plan.summary;
  EXPECT_TRUE(plan.corners.empty());
  for (const CreaseCrossing& c : plan.crossings) {
    EXPECT_TRUE(c.convex);
    EXPECT_NEAR(c.dihedral_deg, 90.0, 1e-6);
    EXPECT_NEAR(c.position[0], kCube, 1e-12);
    EXPECT_NEAR(c.position[2], kCube, 1e-12);
    EXPECT_NEAR(std::abs(c.inward[1]), 1.0, 1e-9);  // along the edge, into the hole
  }
  // The curve is the edge itself.
  for (double t = 0; t <= 1.0; t += 0.1) {
    const Vec3 q = plan.curves[0].curve.at(t);
    EXPECT_NEAR(q[0], kCube, 1e-9);
    EXPECT_NEAR(q[2], kCube, 1e-9);
  }
}

// The crease a pick points at: from a rim vertex on the cube's edge, a pick on the edge beyond
// gives the edge's direction exactly, a pick a little off it too (within the tolerance), and a
// pick on a face away from the edge gives nothing (the caller then keeps the chord). Also
// CreaseCrossing::on_crease lies on the edge, the fit length from the rim.
TEST(SharpEdges, CreaseTangentTowardsAPickFollowsTheEdgeItLiesOn) {
  const Mesh mesh = cube_with_hole(Vec3(kCube, 4, kCube), 2.2);
  const auto holes = find_holes(mesh).holes;
  ASSERT_EQ(holes.size(), 1u);
  const HoleCreasePlan plan = plan_hole_creases(mesh, holes[0]);
  ASSERT_EQ(plan.crossings.size(), 2u) << plan.summary;
  for (const CreaseCrossing& c : plan.crossings) {
    EXPECT_NEAR(c.on_crease[0], kCube, 1e-9);
    EXPECT_NEAR(c.on_crease[2], kCube, 1e-9);
    EXPECT_GT((c.on_crease - c.position).norm(), holes[0].mean_edge_length);
    // Outside the hole: beyond the rim, against the inward direction.
    EXPECT_LT(OpenMesh::dot(c.on_crease - c.position, c.inward), 0.0);
    const double tolerance = holes[0].mean_edge_length;
    const Vec3 outward = -c.inward;
    for (const double off : {0.0, 0.5}) {
      const Vec3 pick = c.position + 1.5 * outward + off * tolerance * Vec3(0, 0, -1);
      const auto t = crease_tangent_towards(mesh, c.vertex, pick, 30.0, tolerance, 1.0);
      ASSERT_TRUE(t) << "pick " << off << " edge lengths off the crease";
      EXPECT_NEAR(OpenMesh::dot(*t, outward), 1.0, 1e-9);
    }
    const Vec3 on_face = c.position + 1.5 * outward + Vec3(0, 0, -3 * tolerance);
    EXPECT_FALSE(crease_tangent_towards(mesh, c.vertex, on_face, 30.0, tolerance, 1.0));
  }
}

TEST(SharpEdges, AutoFillKeepsTheEdgeSharp) {
  Mesh mesh = cube_with_hole(Vec3(kCube, 4, kCube), 2.2);
  const auto holes = find_holes(mesh).holes;
  const testing::Snapshot before = testing::take_snapshot(mesh);
  FillOptions options;
  options.sharp = SharpMode::Auto;
  const FillReport report = fill_holes(mesh, {}, options);
  ASSERT_EQ(report.holes.size(), 1u);
  const HoleFillReport& r = report.holes[0];
  ASSERT_TRUE(r.filled) << r.reason;
  EXPECT_EQ(r.method, FillMethod::CreaseSplit);
  EXPECT_EQ(r.crease_curves, 1u);
  EXPECT_EQ(r.pieces, 2u);
  EXPECT_EQ(testing::check_fill_invariants(before, mesh, report.holes, holes), "");
  // The edge x = z = 8 through the hole lies on the patch, and the patch is the cube's surface.
  const std::vector<std::array<Vec3, 2>> edge{{Vec3(kCube, 2, kCube), Vec3(kCube, 6, kCube)}};
  EXPECT_LT(crease_distance(mesh, r, edge), 1e-9);
  for (const FaceHandle f : r.new_faces) {
    const Vec3 n = mesh.calc_face_normal(f);
    EXPECT_NEAR(std::max(n[0], n[2]), 1.0, 1e-9) << "a patch face is not on the top or the side";
  }
}

TEST(SharpEdges, HoleAtACornerMeetsAtTheCorner) {
  Mesh mesh = cube_with_hole(Vec3(kCube, kCube, kCube), 2.6);
  const auto holes = find_holes(mesh).holes;
  ASSERT_EQ(holes.size(), 1u);
  const HoleCreasePlan plan = plan_hole_creases(mesh, holes[0]);
  ASSERT_EQ(plan.crossings.size(), 3u) << plan.summary;
  ASSERT_EQ(plan.corners.size(), 1u) << plan.summary;
  EXPECT_LT((plan.corners[0] - Vec3(kCube, kCube, kCube)).norm(), 1e-9);
  EXPECT_EQ(plan.curves.size(), 3u);

  const testing::Snapshot before = testing::take_snapshot(mesh);
  FillOptions options;
  options.sharp = SharpMode::Auto;
  const FillReport report = fill_holes(mesh, {}, options);
  const HoleFillReport& r = report.holes.at(0);
  ASSERT_TRUE(r.filled) << r.reason;
  EXPECT_EQ(r.method, FillMethod::CreaseSplit);
  EXPECT_EQ(r.pieces, 3u);
  EXPECT_EQ(testing::check_fill_invariants(before, mesh, report.holes, holes), "");
  const Vec3 corner(kCube, kCube, kCube);
  const std::vector<std::array<Vec3, 2>> edges{{corner, corner - Vec3(2, 0, 0)},
                                               {corner, corner - Vec3(0, 2, 0)},
                                               {corner, corner - Vec3(0, 0, 2)}};
  EXPECT_LT(crease_distance(mesh, r, edges), 1e-9);
}

// A cut below a cube's corner that leaves the corner on its rim (faces of the top and of a side
// keep it, with the top edge between them): the vertical edge crosses the hole and ends at the
// corner. The creases meet on the rim, not inside the hole, so no corner inside it fits (the
// least-squares one is the rim vertex itself); the edge is a straight curve from its crossing
// to the corner vertex, and the patch keeps it exactly (before, both crossings were left
// unmatched and the plain fill cut the edge off).
TEST(SharpEdges, CreaseEndingAtACornerOnTheRimIsSplitAlong) {
  Mesh mesh = cube_with_hole(Vec3(kCube, kCube, kCube - 2.5), 2.05);
  const auto holes = find_holes(mesh).holes;
  ASSERT_EQ(holes.size(), 1u);
  const Vec3 corner(kCube, kCube, kCube);
  const HoleCreasePlan plan = plan_hole_creases(mesh, holes[0]);
  ASSERT_EQ(plan.curves.size(), 1u) << plan.summary;
  EXPECT_TRUE(plan.corners.empty());
  EXPECT_TRUE(plan.unmatched.empty()) << plan.summary;
  const CreaseCurve& curve = plan.curves[0];
  ASSERT_TRUE(curve.to);
  EXPECT_EQ(plan.crossings[*curve.to].position, corner);
  EXPECT_EQ(plan.crossings[curve.from].position, Vec3(kCube, kCube, kCube - 4));
  for (double t = 0; t <= 1.0; t += 0.1) {
    const Vec3 q = curve.curve.at(t);
    EXPECT_NEAR(q[0], kCube, 1e-9);
    EXPECT_NEAR(q[1], kCube, 1e-9);
  }

  const testing::Snapshot before = testing::take_snapshot(mesh);
  const FillReport report = fill_holes(mesh, {}, FillOptions{});
  const HoleFillReport& r = report.holes.at(0);
  ASSERT_TRUE(r.filled) << r.reason;
  EXPECT_EQ(r.method, FillMethod::CreaseSplit) << r.creases;
  EXPECT_EQ(r.pieces, 2u);
  EXPECT_EQ(testing::check_fill_invariants(before, mesh, report.holes, holes), "");
  const std::vector<std::array<Vec3, 2>> edge{{corner - Vec3(0, 0, 4), corner}};
  EXPECT_LT(crease_distance(mesh, r, edge), 1e-9);
  for (const FaceHandle f : r.new_faces) {
    const Vec3 n = mesh.calc_face_normal(f);
    EXPECT_NEAR(std::max(n[0], n[1]), 1.0, 1e-9) << "a patch face is on neither side";
  }
  EXPECT_GE(r.min_angle_deg, 15.0);
}

// Four bent creases (circles from p along t with curvature κ, as the plan continues them) that meet
// in pairs, 20° apart, at two points: the two-corner plan puts its corners exactly there, not at
// one corner of all four. From the tangent lines' meeting point (about 0.2 off) Gauss-Newton steps
// get there in a few rounds; alternating projections, at this angle, are still 5e-4 to 7e-4 off
// after their 100.
TEST(SharpEdges, BentCreasesMeetingInPairsGetTheirTwoCornersExactly) {
  const Mesh mesh = build_mesh(testing::grid_with_round_hole()).mesh;
  const auto holes = find_holes(mesh).holes;  // the grid's outer rim and the round hole
  ASSERT_EQ(holes.size(), 2u);
  const Hole& hole = (holes[0].centroid - Vec3(8, 8, 0)).norm() < 1 ? holes[0] : holes[1];
  ASSERT_LT((hole.centroid - Vec3(8, 8, 0)).norm(), 1e-6);
  const Vec3 left(7, 8, 0.5), right(9.5, 8.4, 0.5);
  HoleCreasePlan plan;
  // In loop order: two creases reach `left`, two `right`; each bends by |κ| = 0.1 out of the
  // plane of its tangent and the z axis.
  const auto add = [&](const Vec3& corner, Vec3 tangent, const Vec3& bend, double length) {
    tangent.normalize();
    Vec3 towards_centre = bend - OpenMesh::dot(bend, tangent) * tangent;
    towards_centre.normalize();
    const double kappa = 0.1;
    const Vec3 curvature = kappa * towards_centre;
    CreaseCrossing c;
    c.loop_index = plan.crossings.size();
    // The circle's point at arc length `length` is the corner.
    c.position = corner - std::sin(kappa * length) / kappa * tangent -
                 (1 - std::cos(kappa * length)) / kappa * towards_centre;
    c.inward = c.bend_inward = tangent;
    c.curvature = curvature;
    c.far_point = c.position - tangent;
    plan.crossings.push_back(c);
  };
  // Each pair 20° apart: the two from below meet at `left`, the two from above at `right`.
  const double sin10 = std::sin(10 * std::numbers::pi / 180),
               cos10 = std::cos(10 * std::numbers::pi / 180);
  add(left, Vec3(sin10, cos10, 0), Vec3(0, 0, 1), 2.0);
  add(left, Vec3(-sin10, cos10, 0.05), Vec3(0, 0, -1), 1.8);
  add(right, Vec3(-sin10, -cos10, 0), Vec3(0, 0, 1), 2.2);
  add(right, Vec3(sin10, -cos10, 0.05), Vec3(1, 1, 1), 1.9);
  const std::vector<std::size_t> crossings{0, 1, 2, 3};
  ASSERT_TRUE(join_at_corners(plan, mesh, hole, crossings, /*line_tolerance=*/2.0,
                              /*two_corner_gain=*/0.5, HermiteOptions{}, 1e-6,
                              [](const Vec3&) { return true; }));
  ASSERT_EQ(plan.corners.size(), 2u);
  ASSERT_EQ(plan.corner_links.size(), 1u);
  EXPECT_LT((plan.corners[0] - left).norm(), 1e-9);
  EXPECT_LT((plan.corners[1] - right).norm(), 1e-9);
  EXPECT_EQ(plan.curves.size(), 4u);
}

// When a split along every curve of a plan cannot be made, a curve is taken out. Where the
// split's patch crossed the mesh, the curve nearest that point (a corner's crease takes the
// corners with it); otherwise the least certain: a loosely joined pair (its tangents over
// CreaseOptions::pair_angle_deg off its curve), then the corners with their creases, then the
// pair that strays most. The crossings freed are reported unmatched, and a plan is not reduced
// to no curve at all.
TEST(SharpEdges, ThePlanLosesTheCurveNearestTheTroubleOrItsLeastCertainOne) {
  const double degree = std::numbers::pi / 180;
  HoleCreasePlan plan;
  for (std::size_t i = 0; i < 7; ++i) {
    CreaseCrossing c;
    c.loop_index = 3 * i;
    plan.crossings.push_back(c);
  }
  // Straight curves in the plane z = 0.
  const auto line = [](const Vec3& a, const Vec3& b) {
    const HermiteCurveResult r = make_hermite_curve({a - (b - a), a, b, b + (b - a)}, {}, 1e-9);
    EXPECT_TRUE(r.curve);
    return r.curve ? *r.curve : HermiteCurve{};
  };
  const auto pair = [&](std::size_t a, std::size_t b, double misfit_deg, double y) {
    CreaseCurve c;
    c.from = a;
    c.to = b;
    c.misfit = misfit_deg * degree;
    c.curve = line(Vec3(0, y, 0), Vec3(10, y, 0));
    plan.curves.push_back(c);
  };
  pair(0, 1, 10, 0);  // along y = 0
  pair(2, 3, 40, 4);  // loose, along y = 4
  plan.corners = {Vec3(5, 8, 0)};
  for (const std::size_t from : {4u, 5u, 6u}) {  // three creases meet at the corner
    CreaseCurve c;
    c.from = from;
    c.corner = 0;
    c.curve = line(Vec3(2.0 * static_cast<double>(from) - 5, 12, 0), Vec3(5, 8, 0));
    plan.curves.push_back(c);
  }
  const CreaseOptions options;  // pair_angle_deg 35

  const auto first = plan_without_weakest_curve(plan, options);
  ASSERT_TRUE(first);
  ASSERT_EQ(first->curves.size(), 4u);
  EXPECT_EQ(first->corners.size(), 1u);
  EXPECT_EQ(first->unmatched, (std::vector<std::size_t>{2, 3}));
  EXPECT_EQ(first->summary, "7 crease crossings, 4 curves meeting at a corner, 2 unmatched");

  const auto second = plan_without_weakest_curve(*first, options);
  ASSERT_TRUE(second);
  ASSERT_EQ(second->curves.size(), 1u);
  EXPECT_EQ(second->curves[0].from, 0u);
  EXPECT_TRUE(second->corners.empty());
  EXPECT_EQ(second->unmatched, (std::vector<std::size_t>{2, 3, 4, 5, 6}));
  EXPECT_EQ(second->summary, "7 crease crossings, 1 curve, 5 unmatched");
  EXPECT_FALSE(plan_without_weakest_curve(*second, options));

  // The split crossed the mesh beside the most certain pair: that pair goes.
  const auto beside = plan_without_weakest_curve(plan, options, Vec3(6, 0.5, 0.2));
  ASSERT_TRUE(beside);
  ASSERT_EQ(beside->curves.size(), 4u);
  EXPECT_EQ(beside->unmatched, (std::vector<std::size_t>{0, 1}));
  // ... or near a crease to the corner: the corner goes with its creases.
  const auto near_corner = plan_without_weakest_curve(plan, options, Vec3(4.9, 9, 0));
  ASSERT_TRUE(near_corner);
  ASSERT_EQ(near_corner->curves.size(), 2u);
  EXPECT_TRUE(near_corner->corners.empty());

  // The corners alone (the fill's retry that leaves them out starts from the whole plan): both
  // pairs stay, the corner's crossings are freed; a plan with no corners has none to lose.
  const auto no_corners = plan_without_corners(plan);
  ASSERT_TRUE(no_corners);
  ASSERT_EQ(no_corners->curves.size(), 2u);
  EXPECT_TRUE(no_corners->corners.empty());
  EXPECT_EQ(no_corners->unmatched, (std::vector<std::size_t>{4, 5, 6}));
  EXPECT_FALSE(plan_without_corners(*no_corners));

  // A corner on a pair's curve (a crease that ends on it): without the corner the pair is back
  // whole, and the crease that ended there is unmatched.
  HoleCreasePlan tee = plan;
  tee.corners = {Vec3(5, 0, 0)};
  tee.curves.erase(tee.curves.begin() + 2, tee.curves.end());  // the corner's creases
  tee.pairs_split_at_corners = {tee.curves[0]};
  tee.curves.erase(tee.curves.begin());  // the pair along y = 0, split at x = 5
  for (const auto& [from, end] : {std::pair{0u, 0.0}, std::pair{1u, 10.0}, std::pair{4u, 5.0}}) {
    CreaseCurve c;
    c.from = from;
    c.corner = 0;
    c.curve = line(Vec3(end, from == 4u ? 12.0 : 0.0, 0), Vec3(5, 0, 0));
    tee.curves.push_back(c);
  }
  const auto no_tee = plan_without_corners(tee);
  ASSERT_TRUE(no_tee);
  ASSERT_EQ(no_tee->curves.size(), 2u);
  EXPECT_TRUE(no_tee->pairs_split_at_corners.empty());
  EXPECT_EQ(no_tee->curves[1].from, 0u);
  EXPECT_EQ(no_tee->curves[1].to, std::optional<std::size_t>(1));
  EXPECT_EQ(no_tee->unmatched, (std::vector<std::size_t>{4}));
}

// A 45 deg fold across a hole (a chamfer of a CAD part): below the crease angle of 50 deg, but
// every other edge at the crossings is flat, so the crossings count as strong and are joined;
// with the clean rule off they are not. (A scan's crossing of that size among other bends is
// the rocker arm's, SharpCasesPicked.PointsPickedOnTheCreaseRetainItCloserThanThePlainFill.)
TEST(SharpEdges, CleanFoldBelowTheCreaseAngleIsACrease) {
  const double slope = std::tan(45.0 * std::numbers::pi / 180.0);
  const Mesh mesh = build_mesh(testing::grid_with_round_hole([&](double x, double) {
                      return x > 8 ? (x - 8) * slope : 0.0;
                    })).mesh;
  const auto holes = find_holes(mesh).holes;
  ASSERT_EQ(holes.size(), 2u);  // the round hole and the grid's border
  const Hole& hole = holes[0].perimeter < holes[1].perimeter ? holes[0] : holes[1];
  const HoleCreasePlan plan = plan_hole_creases(mesh, hole);
  ASSERT_EQ(plan.crossings.size(), 2u) << plan.summary;
  ASSERT_EQ(plan.curves.size(), 1u) << plan.summary;
  for (const CreaseCrossing& c : plan.crossings) {
    EXPECT_NEAR(c.dihedral_deg, 45.0, 1e-6);
    EXPECT_NEAR(c.other_bends_deg, 0.0, 1e-6);
    EXPECT_NEAR(c.position[0], 8.0, 1e-12);
  }
  CreaseOptions off;
  off.clean_crease_angle_deg = off.crease_angle_deg;
  EXPECT_TRUE(plan_hole_creases(mesh, hole, off).curves.empty());
}

// A fillet: a plane turning by 60° over three strips 0.1 wide, each bent 20° from the next (no
// edge of it is a crease), the rest of the grid 1 apart. A hole cut across it meets each side
// of the band at three consecutive rim vertices; the plan takes each band as one crossing of the
// band's whole turn, at its middle strip edge, and joins the two. On the same grid with the
// strips 1 wide (an evenly meshed bend, as a scan's) nothing is found.
MeshSoup filleted_grid(double strip) {
  std::vector<double> xs;
  for (int i = 0; i <= 8; ++i) xs.push_back(i);
  for (int k = 1; k <= 3; ++k) xs.push_back(8 + k * strip);
  for (int i = 1; i <= 8; ++i) xs.push_back(8 + 3 * strip + i);
  // Height along x: flat, then slopes of 20°, 40° and 60° over the strips, then 60° on.
  const auto height = [&](double x) {
    double z = 0;
    for (int k = 0; k < 3; ++k) {
      const double from = 8 + k * strip;
      const double to = k < 2 ? from + strip : std::numeric_limits<double>::infinity();
      if (x > from)
        z += (std::min(x, to) - from) * std::tan((k + 1) * 20.0 * std::numbers::pi / 180);
    }
    return z;
  };
  MeshSoup soup;
  const int ny = 21;
  for (int j = 0; j < ny; ++j)
    for (const double x : xs) soup.points.push_back(Vec3(x, j, height(x)));
  const auto at = [&](std::size_t i, int j) {
    return static_cast<std::uint32_t>(static_cast<std::size_t>(j) * xs.size() + i);
  };
  for (int j = 0; j + 1 < ny; ++j)
    for (std::size_t i = 0; i + 1 < xs.size(); ++i) {
      soup.triangles.push_back({at(i, j), at(i + 1, j), at(i + 1, j + 1)});
      soup.triangles.push_back({at(i, j), at(i + 1, j + 1), at(i, j + 1)});
    }
  return soup;
}

TEST(SharpEdges, AFilletIsOneCreaseCrossingTheRimAtItsMiddle) {
  for (const double strip : {0.1, 1.0}) {
    SCOPED_TRACE(strip);
    const MeshSoup grid = filleted_grid(strip);
    const Mesh mesh = build_mesh(testing::remove_faces(grid, [&](const Vec3& c) {
                        return std::hypot(c[0] - (8 + 1.5 * strip), c[1] - 10) < 4.0;
                      })).mesh;
    const auto holes = find_holes(mesh).holes;
    ASSERT_EQ(holes.size(), 2u);  // the cut and the grid's border
    const Hole& hole = holes[0].perimeter < holes[1].perimeter ? holes[0] : holes[1];
    const HoleCreasePlan plan = plan_hole_creases(mesh, hole);
    if (strip > 0.5) {
      EXPECT_TRUE(plan.crossings.empty()) << plan.summary;
      continue;
    }
    ASSERT_EQ(plan.crossings.size(), 2u) << plan.summary;
    ASSERT_EQ(plan.curves.size(), 1u) << plan.summary;
    for (const CreaseCrossing& c : plan.crossings) {
      EXPECT_NEAR(c.dihedral_deg, 60.0, 1e-6);
      EXPECT_FALSE(c.convex);
      EXPECT_NEAR(c.position[0], 8 + strip, 1e-12);   // the middle strip edge
      EXPECT_NEAR(std::abs(c.inward[1]), 1.0, 1e-9);  // along the fillet, into the hole
    }
    // Filled split along it, clean.
    Mesh filled = mesh;
    const testing::Snapshot before = testing::take_snapshot(filled);
    const HoleFillReport r = fill_hole(filled, hole, FillOptions{});
    ASSERT_TRUE(r.filled) << r.reason;
    EXPECT_EQ(r.method, FillMethod::CreaseSplit) << r.creases;
    EXPECT_TRUE(testing::check_fill_invariants(before, filled, {r}, holes).empty());
  }
}

TEST(SharpEdges, SmoothSurfacesHaveNoCreases) {
  const MeshSoup sphere = testing::uv_sphere(1.0, 48, 24);
  const Mesh mesh = build_mesh(testing::remove_faces(sphere, [](const Vec3& c) {
                      return (c - Vec3(1, 0, 0)).norm() < 0.3;
                    })).mesh;
  const auto holes = find_holes(mesh).holes;
  ASSERT_EQ(holes.size(), 1u);
  const HoleCreasePlan plan = plan_hole_creases(mesh, holes[0]);
  EXPECT_TRUE(plan.crossings.empty()) << plan.summary;
  EXPECT_TRUE(plan.curves.empty());
}

//! The square (0, 0)-(2, 2) with its edges' midpoints: 8 boundary vertices, counter-clockwise.
std::vector<Vec3> square_of_eight() {
  return {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {2, 1, 0}, {2, 2, 0}, {1, 2, 0}, {0, 2, 0}, {0, 1, 0}};
}

//! The opposite vertices of a planar loop's boundary edges: below each edge's midpoint.
std::vector<Vec3> opposite_below(const std::vector<Vec3>& loop) {
  std::vector<Vec3> opposite;
  for (std::size_t i = 0; i < loop.size(); ++i)
    opposite.push_back(0.5 * (loop[i] + loop[(i + 1) % loop.size()]) + Vec3(0, 0, -1));
  return opposite;
}

//! Every curve edge of \p t is used by exactly two triangles (one per side), every other
//! interior edge by two, every edge of the \p loop_size boundary vertices by one: a manifold disk.
void expect_manifold_disk(const CurveSplitTriangulation& t, std::size_t loop_size) {
  const int n = static_cast<int>(loop_size);
  std::map<std::pair<int, int>, int> uses;
  for (const auto& tri : t.triangles)
    for (int k = 0; k < 3; ++k) {
      const int a = tri[static_cast<std::size_t>(k)],
                b = tri[static_cast<std::size_t>((k + 1) % 3)];
      ++uses[{std::min(a, b), std::max(a, b)}];
    }
  for (const auto& [a, b] : t.curve_edges) EXPECT_EQ((uses[{std::min(a, b), std::max(a, b)}]), 2);
  for (const auto& [edge, count] : uses) {
    const bool loop_edge = edge.second < n && (edge.second - edge.first == 1 ||
                                               (edge.first == 0 && edge.second == n - 1));
    EXPECT_EQ(count, loop_edge ? 1 : 2) << edge.first << "-" << edge.second;
  }
}

TEST(CurveSplit, ChordSplitsASquareIntoTwoRegions) {
  // A planar 8-gon (square with edge midpoints), curve from vertex 1 to vertex 5 via 2 points.
  const std::vector<Vec3> loop = square_of_eight();
  const std::vector<Vec3> opposite = opposite_below(loop);
  CurveSplitInput in;
  in.loop = loop;
  in.opposite = opposite;
  in.curves.push_back({1, 5, {Vec3(1, 0.67, 0), Vec3(1, 1.33, 0)}});
  const CurveSplitTriangulation t = triangulate_along_curves(in);
  ASSERT_TRUE(t.ok) << t.failure;
  EXPECT_EQ(t.pieces, 2u);
  EXPECT_EQ(t.new_points.size(), 2u);
  ASSERT_EQ(t.curve_edges.size(), 3u);
  expect_manifold_disk(t, loop.size());
  // The two regions lie on the two sides of the curve x = 1.
  auto centroid_x = [&](const std::array<int, 3>& tri) {
    double x = 0;
    for (const int v : tri)
      x += (v < 8 ? loop[static_cast<std::size_t>(v)]
                  : t.new_points[static_cast<std::size_t>(v - 8)])[0] /
           3.0;
    return x;
  };
  const bool first_left = centroid_x(t.triangles[0]) < 1;
  for (std::size_t i = 0; i < t.triangles.size(); ++i) {
    const bool same_piece = t.piece_of_triangle[i] == t.piece_of_triangle[0];
    EXPECT_EQ(centroid_x(t.triangles[i]) < 1, same_piece ? first_left : !first_left) << i;
  }
}

TEST(CurveSplit, ARimVertexWithCurvesToTheRimAndToACornerOrdersThemByTheLoop) {
  // The square of 8 boundary vertices, a corner at (1, 1.5) reached from vertices 4 and 6, and
  // vertex 1 with two curves: up to the corner and up-left to vertex 7 (a corner on the rim that
  // move_corner_to_rim turned into vertex 1: one crease ends there, its link leaves to the
  // other corner). Around vertex 1 the curve to the corner comes first from vertex 2 (the
  // corner's rim ends, 4 and 6, are nearer along the loop than 7): four regions, a manifold disk.
  const std::vector<Vec3> loop = square_of_eight();
  const std::vector<Vec3> opposite = opposite_below(loop);
  CurveSplitInput in;
  in.loop = loop;
  in.opposite = opposite;
  in.corners = {Vec3(1, 1.5, 0)};
  in.curves = {{4, -1, {}}, {6, -1, {}}, {1, -1, {Vec3(1, 0.75, 0)}}, {1, 7, {}}};
  const CurveSplitTriangulation t = triangulate_along_curves(in);
  ASSERT_TRUE(t.ok) << t.failure;
  EXPECT_EQ(t.pieces, 4u);
  expect_manifold_disk(t, loop.size());
}

TEST(CurveSplit, RejectsCurvesThatDoNotEndOnTheLoop) {
  const std::vector<Vec3> loop{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  const std::vector<Vec3> opposite(4, Vec3(0.5, 0.5, -1));
  CurveSplitInput in;
  in.loop = loop;
  in.opposite = opposite;
  in.curves.push_back({0, 7, {}});
  EXPECT_FALSE(triangulate_along_curves(in).ok);
  in.curves = {{0, -1, {}}};  // to a corner that was not given
  EXPECT_FALSE(triangulate_along_curves(in).ok);
}

TEST(CurveSplit, CurveAlongABoundaryEdgeAddsNothing) {
  // A crease that runs along a boundary edge is already in the mesh: the curve is dropped and
  // the hole is filled as one region.
  const std::vector<Vec3> loop{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  const std::vector<Vec3> opposite(4, Vec3(0.5, 0.5, -1));
  CurveSplitInput in;
  in.loop = loop;
  in.opposite = opposite;
  in.curves = {{0, 1, {}}};
  const CurveSplitTriangulation t = triangulate_along_curves(in);
  ASSERT_TRUE(t.ok) << t.failure;
  EXPECT_EQ(t.pieces, 1u);
  EXPECT_EQ(t.triangles.size(), 2u);
  EXPECT_TRUE(t.curve_edges.empty());
}

TEST(CurveSplit, CurveHuggingABoundaryEdgeIsThatEdge) {
  // A crease between neighbouring boundary vertices sampled a hair off their edge (a pair along
  // a boss's rim): the region between would be a sliver with both sides fixed. Within a tenth of
  // the edge's length it is the edge, and the hole is one region; bowed farther it is kept.
  const std::vector<Vec3> loop{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  const std::vector<Vec3> opposite(4, Vec3(0.5, 0.5, -1));
  CurveSplitInput in;
  in.loop = loop;
  in.opposite = opposite;
  in.curves = {{0, 1, {Vec3(0.5, 0.01, 0)}}};
  const CurveSplitTriangulation hugging = triangulate_along_curves(in);
  ASSERT_TRUE(hugging.ok) << hugging.failure;
  EXPECT_EQ(hugging.pieces, 1u);
  EXPECT_TRUE(hugging.curve_edges.empty());
  in.curves = {{0, 1, {Vec3(0.5, 0.3, 0)}}};
  const CurveSplitTriangulation bowed = triangulate_along_curves(in);
  ASSERT_TRUE(bowed.ok) << bowed.failure;
  EXPECT_EQ(bowed.pieces, 2u);
  EXPECT_EQ(bowed.curve_edges.size(), 2u);
}

TEST(CurveSplit, CurveHuggingSeveralBoundaryEdgesIsThatStretch) {
  // A crease that the rim follows for two edges (0 -> 1 -> 2 of a hexagon's half, flattened):
  // the pair's curve 0 -> 2 runs a hair inside those edges, its samples between the rim's
  // vertices, so no sample is near vertex 1 and the curve is not cut there. Within a tenth of
  // an edge's length of that stretch it is the stretch, and the hole is one region; the same
  // samples bowed farther in split it, and a chord 0 -> 2 with no samples is kept.
  const std::vector<Vec3> loop{{0, 0, 0}, {1, 0.05, 0}, {2, 0, 0}, {2, 1, 0}, {0, 1, 0}};
  const std::vector<Vec3> opposite(5, Vec3(1, 0.5, -1));
  CurveSplitInput in;
  in.loop = loop;
  in.opposite = opposite;
  in.curves = {{0, 2, {Vec3(0.4, 0.03, 0), Vec3(1.6, 0.03, 0)}}};
  const CurveSplitTriangulation hugging = triangulate_along_curves(in);
  ASSERT_TRUE(hugging.ok) << hugging.failure;
  EXPECT_EQ(hugging.pieces, 1u);
  EXPECT_TRUE(hugging.curve_edges.empty());
  in.curves = {{0, 2, {Vec3(0.4, 0.3, 0), Vec3(1.6, 0.3, 0)}}};
  const CurveSplitTriangulation bowed = triangulate_along_curves(in);
  ASSERT_TRUE(bowed.ok) << bowed.failure;
  EXPECT_EQ(bowed.pieces, 2u);
  in.curves = {{0, 2, {}}};
  const CurveSplitTriangulation chord = triangulate_along_curves(in);
  ASSERT_TRUE(chord.ok) << chord.failure;
  EXPECT_EQ(chord.pieces, 2u);
  EXPECT_EQ(chord.curve_edges.size(), 1u);
}

TEST(CurveSplit, CurvePassingByABoundaryVertexIsCutThere) {
  // A hexagon split by a curve 0 -> 3 whose middle sample lies on the boundary vertex 2's
  // doorstep (the crease runs through it): the curve becomes 0 -> 2 and 2 -> 3, the latter a
  // boundary edge (dropped), and no sliver is left between the sample and vertex 2.
  std::vector<Vec3> loop;
  for (int i = 0; i < 6; ++i) {
    const double a = i * std::numbers::pi / 3;
    loop.push_back({std::cos(a), std::sin(a), 0});
  }
  const std::vector<Vec3> opposite(6, Vec3(0, 0, -1));
  CurveSplitInput in;
  in.loop = loop;
  in.opposite = opposite;
  in.curves = {{0, 3, {0.97 * loop[2]}}};
  // Far from vertex 2: kept.
  CurveSplitInput plain = in;
  plain.curves = {{0, 3, {Vec3(0, 0, 0)}}};
  const CurveSplitTriangulation kept = triangulate_along_curves(plain);
  ASSERT_TRUE(kept.ok) << kept.failure;
  EXPECT_EQ(kept.new_points.size(), 1u);
  const CurveSplitTriangulation cut = triangulate_along_curves(in);
  ASSERT_TRUE(cut.ok) << cut.failure;
  EXPECT_TRUE(cut.new_points.empty());
  EXPECT_EQ(cut.pieces, 2u);
  std::vector<TrianglePoints> triangles;
  for (const auto& t : cut.triangles)
    triangles.push_back({loop[static_cast<std::size_t>(t[0])], loop[static_cast<std::size_t>(t[1])],
                         loop[static_cast<std::size_t>(t[2])]});
  EXPECT_GT(triangle_quality(triangles).min_angle_deg, 25.0);
}

//! A crossing on the circle of radius \p r about the origin in the plane z = 0 at angle \p at
//! (radians), its crease running outside the hole the other way round (clockwise when \p ccw,
//! i.e. continuing counter-clockwise into the hole), with \p curvature_scale times the circle's
//! curvature and points along the circle by the rim.
CreaseCrossing ring_crossing(double r, double at, bool ccw, double curvature_scale) {
  const auto on_circle = [r](double phi) { return Vec3(r * std::cos(phi), r * std::sin(phi), 0); };
  CreaseCrossing c;
  c.position = on_circle(at);
  const double way = ccw ? 1.0 : -1.0;
  c.inward = way * Vec3(-std::sin(at), std::cos(at), 0);
  c.curvature = -curvature_scale / r * Vec3(std::cos(at), std::sin(at), 0);
  for (int k = 0; k < 4; ++k) c.near_rim.push_back(on_circle(at - way * 0.1 * k));
  return c;
}

// A bore's rim cut by a hole: the arc between two crossings continues both creases, however far
// it turns inside the hole (here 290 deg, beyond any cubic Hermite curve); a straight crease, a
// bend the wrong way and tangents that disagree make no arc.
TEST(SharpEdges, CreasesOnOneCircleAreJoinedByItsArc) {
  const double r = 0.5;
  const double start = 0.0, end = 290.0 * std::numbers::pi / 180.0;
  const CreaseCrossing a = ring_crossing(r, start, true, 1.0);
  const CreaseCrossing b = ring_crossing(r, end, false, 1.0);
  double score = -1;
  const auto arc = crease_arc_between(a, b, 60, 35, 2.0, &score);
  ASSERT_TRUE(arc);
  EXPECT_NEAR(score, 0.0, 1e-9);
  EXPECT_NEAR(arc->radius, r, 1e-9);
  EXPECT_NEAR(arc->centre.norm(), 0.0, 1e-9);
  EXPECT_NEAR(arc->angle, end - start, 1e-9);
  EXPECT_NEAR((arc->at(1.0) - b.position).norm(), 0.0, 1e-9);
  for (double t = 0; t <= 1.0; t += 0.125) EXPECT_NEAR(arc->at(t).norm(), r, 1e-9);
  // Halfway round the arc it passes the far side of the circle (145 deg), not the chord.
  const double half = end / 2;
  EXPECT_NEAR((arc->at(0.5) - Vec3(r * std::cos(half), r * std::sin(half), 0)).norm(), 0, 1e-9);

  // Tangents fitted with a bias (the ends' own points fix the circle): still the same circle.
  CreaseCrossing tilted_a = a, tilted_b = b;
  const double tilt = 8.0 * std::numbers::pi / 180.0;
  tilted_a.inward = std::cos(tilt) * a.inward + std::sin(tilt) * Vec3(1, 0, 0);
  tilted_b.inward =
      std::cos(tilt) * b.inward + std::sin(tilt) * Vec3(std::cos(end), std::sin(end), 0);
  const auto refit = crease_arc_between(tilted_a, tilted_b, 60, 35, 2.0);
  ASSERT_TRUE(refit);
  EXPECT_NEAR(refit->radius, r, 1e-6);

  // Straight creases (no curvature) are the straight pairing's, not an arc's.
  EXPECT_FALSE(crease_arc_between(ring_crossing(r, start, true, 0.0),
                                  ring_crossing(r, end, false, 0.0), 60, 35, 2.0));
  // Creases bending away from the arc's centre, or three times too sharply.
  EXPECT_FALSE(crease_arc_between(ring_crossing(r, start, true, -1.0), b, 60, 35, 2.0));
  EXPECT_FALSE(crease_arc_between(ring_crossing(r, start, true, 3.0), b, 60, 35, 2.0));
  // Both creases leaving the same way round do not meet on one circle.
  EXPECT_FALSE(crease_arc_between(a, ring_crossing(r, end, true, 1.0), 60, 35, 2.0));
  // A factor below 1 turns arcs off.
  EXPECT_FALSE(crease_arc_between(a, b, 60, 35, 0.0));
}

}  // namespace
}  // namespace touchmend::geometry
