// Sharp-edge retaining on a filled hole (seed 000 §4.2, Algorithms V-VII): the guiding surface
// and curtain coordinates, snapping, the push-down step (stops at the curve; with a depth,
// past it; refuses without motion or off the patch), smoothing by normal propagation, and the
// whole sharpen pipeline (both variants) on a hole across a cube's edge.

#include "server/geometry/edge_retaining.h"

#include <algorithm>
#include <map>
#include <set>
#include <string>

#include <gtest/gtest.h>

#include "server/geometry/hole_filling.h"
#include "server/geometry/mesh_build.h"
#include "server/geometry/mesh_intersections.h"
#include "server/geometry/metrics.h"
#include "server/geometry/patch_quality.h"
#include "server/geometry/sharpen.h"
#include "tests/support/mesh_factory.h"

namespace touchmend::geometry {
namespace {

HermiteCurve straight(const Vec3& a, const Vec3& b) {
  const auto r = make_hermite_curve({a - (b - a), a, b, b + (b - a)}, {}, 1e-12);
  return *r.curve;
}

TEST(GuideSurface, CurtainCoordinatesAreCurveParameterAndHeight) {
  const GuideSurface g = make_guide_surface(straight({0, 0, 0}, {4, 0, 0}), {0, 0, 1}, 1.0, 2.0);
  ASSERT_EQ(g.samples.size(), 5u);
  EXPECT_EQ(g.triangles().size(), 8u);
  const auto c = curtain_coordinates(g, {2.5, 0, 0.75}, 1e-9);
  ASSERT_TRUE(c);
  EXPECT_NEAR(c->t, 2.5, 1e-12);  // polyline parameter: segment 2, halfway
  EXPECT_NEAR(c->s, 0.75, 1e-12);
  EXPECT_EQ(c->side, 1);
  EXPECT_FALSE(curtain_coordinates(g, {2.5, 0.5, 0}, 1e-3));  // off the curtain
}

//! A flat 6x6 grid with the middle 2x2 cells cut out and filled (flat), so the patch has
//! interior vertices after refinement; the state knows the patch and the boundary.
struct FilledGrid {
  Mesh mesh;
  SharpEdgeState state;
};

FilledGrid filled_grid(int refine = 3) {
  FilledGrid g;
  g.mesh = build_mesh(testing::remove_faces(testing::grid(6, 6), [](const Vec3& c) {
             return c[0] > 2 && c[0] < 4 && c[1] > 2 && c[1] < 4;
           })).mesh;
  const auto holes = find_holes(g.mesh).holes;
  const Hole* inner = nullptr;
  for (const Hole& h : holes)
    if (h.loop.size() == 8) inner = &h;
  FillOptions fill;
  fill.shape = PatchShape::Flat;
  fill.refine_iterations = refine;
  const HoleFillReport r = fill_hole(g.mesh, *inner, fill);
  EXPECT_TRUE(r.filled);
  g.state.patch = r.new_faces;
  for (const VertexHandle v : inner->loop) g.state.boundary.insert(v.idx());
  return g;
}

TEST(SnapToGuide, PutsVerticesOnTheCurtainAndChainsThem) {
  FilledGrid g = filled_grid();
  // A curve across the hole from (2, 3) to (4, 3) (boundary midpoints of the left and right
  // sides), curtain along +z.
  g.state.guide = make_guide_surface(straight({2, 3, 0}, {4, 3, 0}), {0, 0, 1}, 0.5, 1.0);
  const SnapReport r = snap_to_guide(g.mesh, g.state);
  EXPECT_GT(r.crossings, 0u);
  EXPECT_FALSE(g.state.on_guide.empty());
  for (const auto& [index, c] : g.state.on_guide) {
    const Vec3 p = g.mesh.point(VertexHandle(index));
    EXPECT_NEAR(p[1], 3.0, 1e-9) << "vertex " << index << " not on the curtain y = 3";
    EXPECT_FALSE(g.state.boundary.count(index));
  }
  // No patch edge crosses the curtain any more.
  for (const FaceHandle f : g.state.patch)
    for (const HalfedgeHandle h : g.mesh.fh_range(f)) {
      const double y0 = g.mesh.point(g.mesh.from_vertex_handle(h))[1] - 3;
      const double y1 = g.mesh.point(g.mesh.to_vertex_handle(h))[1] - 3;
      EXPECT_FALSE((y0 > 1e-9 && y1 < -1e-9) || (y0 < -1e-9 && y1 > 1e-9));
    }
  EXPECT_TRUE(validate_mesh(g.mesh).is_clean());
}

TEST(PushDown, StepsToTheCurveAndStopsOrGoesToTheDepth) {
  FilledGrid g = filled_grid();
  // The curve 0.5 below the flat patch: pushing moves curtain vertices down to z = -0.5.
  g.state.guide = make_guide_surface(straight({2, 3, -0.5}, {4, 3, -0.5}), {0, 0, 1}, 0.5, 2.0);
  snap_to_guide(g.mesh, g.state);
  ASSERT_FALSE(g.state.on_guide.empty());
  const auto [index, c] = *g.state.on_guide.begin();
  EXPECT_NEAR(c.s, 0.5, 1e-9);
  const VertexHandle v(index);
  FaceHandle touched;
  for (const FaceHandle f : g.mesh.vf_range(v)) touched = f;
  const Vec3 proxy = g.mesh.point(v) + Vec3(0, 0, 0.01);
  PushOptions push;
  push.step = 0.2;
  PushResult r = push_down(g.mesh, g.state, proxy, proxy - Vec3(0.1, 0, 0), touched, push);
  ASSERT_TRUE(r.moved) << r.why_not;
  EXPECT_EQ(r.vertex, v);
  EXPECT_NEAR(g.mesh.point(v)[2], -0.2, 1e-9);
  EXPECT_FALSE(r.at_limit);
  for (int i = 0; i < 5; ++i)
    push_down(g.mesh, g.state, proxy, proxy - Vec3(0.1, 0, 0), touched, push);
  EXPECT_NEAR(g.mesh.point(v)[2], -0.5, 1e-9);  // stopped at the curve
  // The vertex is at the curve: the next curtain vertex of the face (or of the triangles
  // around it) moves instead, and once all of them are there the push is refused.
  for (int i = 0; i < 20; ++i)
    push_down(g.mesh, g.state, proxy, proxy - Vec3(0.1, 0, 0), touched, push);
  r = push_down(g.mesh, g.state, proxy, proxy - Vec3(0.1, 0, 0), touched, push);
  EXPECT_FALSE(r.moved);
  EXPECT_NE(r.why_not.find("already at the curve"), std::string::npos) << r.why_not;
  push.depth = 0.3;  // past the curve by at most 0.3
  for (int i = 0; i < 5; ++i)
    push_down(g.mesh, g.state, proxy, proxy - Vec3(0.1, 0, 0), touched, push);
  EXPECT_NEAR(g.mesh.point(v)[2], -0.8, 1e-9);
  EXPECT_TRUE(g.state.moved.count(index));
  // Refusals: no motion, a face outside the patch, a zero step.
  EXPECT_FALSE(push_down(g.mesh, g.state, proxy, proxy, touched, push).moved);
  EXPECT_FALSE(push_down(g.mesh, g.state, proxy, proxy - Vec3(1, 0, 0), FaceHandle(0), push).moved);
  push.step = 0;
  EXPECT_FALSE(push_down(g.mesh, g.state, proxy, proxy - Vec3(1, 0, 0), touched, push).moved);
}

// Two curtain vertices joined by an edge at (almost) the same place along the curve: once the
// first is down, pushing the second onto it would make the triangles at their edge needles.
// The push stops short of that, says why, and leaves no triangle under the degenerate angle.
//! filled_grid(5) with a straight curtain off the grid's symmetry line, snapped.
FilledGrid snapped_grid() {
  FilledGrid g = filled_grid(5);
  g.state.guide =
      make_guide_surface(straight({2, 2.9, -0.5}, {4, 2.9, -0.5}), {0, 0, 1}, 0.25, 2.0);
  snap_to_guide(g.mesh, g.state);
  return g;
}

//! Curtain vertex \p v lifted half a unit straight above curtain vertex \p below (at the same
//! place along the curve): its step down would end on \p below, a needle.
void lift_above(FilledGrid& g, VertexHandle v, VertexHandle below) {
  CurtainPoint& c = g.state.on_guide[v.idx()];
  c.t = g.state.on_guide[below.idx()].t;
  c.s = 0.5;
  g.mesh.set_point(v, g.mesh.point(below) + 0.5 * g.state.guide.normal);
}

double min_angle_around(const Mesh& mesh, VertexHandle v) {
  const std::vector<FaceHandle> faces(mesh.vf_range(v).begin(), mesh.vf_range(v).end());
  return min_angle_deg(mesh, faces);
}

TEST(PushDown, StopsWhereItWouldLeaveADegenerateTriangle) {
  FilledGrid g = snapped_grid();
  // A curtain vertex and a curtain neighbour of it.
  VertexHandle first, second;
  for (const auto& [index, c] : g.state.on_guide) {
    for (const VertexHandle w : g.mesh.vv_range(VertexHandle(index)))
      if (g.state.on_guide.count(w.idx())) {
        first = VertexHandle(index);
        second = w;
        break;
      }
    if (first.is_valid()) break;
  }
  ASSERT_TRUE(first.is_valid() && second.is_valid());
  PushOptions push;
  push.step = 0.05;
  const auto sweep_at = [&](VertexHandle v, int samples) {
    FaceHandle touched;
    for (const FaceHandle f : g.mesh.vf_range(v)) touched = f;
    const Vec3 proxy = g.mesh.point(v) + Vec3(0, 0, 0.01);
    PushResult last;
    for (int i = 0; i < samples; ++i) {
      last = push_down(g.mesh, g.state, proxy, proxy - Vec3(0.1, 0, 0), touched, push);
      if (!last.moved || last.vertex != v) break;
    }
    return last;
  };
  push_all(g.mesh, g.state, {});  // every curtain vertex down to the curve ...
  lift_above(g, second, first);   // ... then the second lifted back up above the first
  const PushResult r = sweep_at(second, 100);
  EXPECT_FALSE(r.moved);
  EXPECT_NE(r.why_not.find("degenerate triangle"), std::string::npos) << r.why_not;
  EXPECT_GT(g.state.on_guide[second.idx()].s, 0.0);  // stopped above the curve
  EXPECT_GE(min_angle_around(g.mesh, second), kDegenerateAngleDeg);
}

TEST(PushDown, PassesOverAVertexWhoseStepWouldLeaveADegenerateTriangle) {
  FilledGrid g = snapped_grid();
  // A curtain vertex with two curtain neighbours.
  VertexHandle first, second, third;
  for (const auto& [index, c] : g.state.on_guide) {
    std::vector<VertexHandle> on;
    for (const VertexHandle w : g.mesh.vv_range(VertexHandle(index)))
      if (g.state.on_guide.count(w.idx())) on.push_back(w);
    if (on.size() >= 2) {
      second = VertexHandle(index);
      first = on[0];
      third = on[1];
      break;
    }
  }
  ASSERT_TRUE(second.is_valid());
  push_all(g.mesh, g.state, {});
  // The second lifted straight above the first (its step down would make a needle), the third
  // lifted above its own place on the curve (free to go down).
  lift_above(g, second, first);
  g.state.on_guide[third.idx()].s = 0.5;
  g.mesh.set_point(third, g.mesh.point(third) + 0.5 * g.state.guide.normal);
  FaceHandle touched;
  for (const FaceHandle f : g.mesh.vf_range(second))
    if (std::find(g.state.patch.begin(), g.state.patch.end(), f) != g.state.patch.end())
      touched = f;
  ASSERT_TRUE(touched.is_valid());
  // The sweep passes right over the second, the nearest: it goes down until its next step would
  // make a needle, and then the third takes the samples.
  const Vec3 proxy = g.mesh.point(second) + Vec3(0, 0, 0.01);
  PushOptions push;
  push.step = 0.05;
  std::map<int, int> steps;
  PushResult r;
  for (int i = 0; i < 60; ++i) {
    r = push_down(g.mesh, g.state, proxy, proxy - Vec3(0.1, 0, 0), touched, push);
    if (!r.moved) break;
    ++steps[r.vertex.idx()];
  }
  EXPECT_FALSE(r.moved);
  EXPECT_NE(r.why_not.find("degenerate triangle"), std::string::npos) << r.why_not;
  EXPECT_GE(steps[second.idx()], 1);
  EXPECT_GE(steps[third.idx()], 10);  // 0.5 down in steps of 0.05 (one more for rounding)
  EXPECT_EQ(steps.size(), 2u);
  EXPECT_GT(g.state.on_guide[second.idx()].s, 0.0);  // stopped above the curve
  EXPECT_EQ(g.state.on_guide[third.idx()].s, 0.0);   // at the curve
  EXPECT_GE(min_angle_around(g.mesh, second), kDegenerateAngleDeg);
  EXPECT_GE(min_angle_around(g.mesh, third), kDegenerateAngleDeg);
}

TEST(PushDown, MovesOnToTheTouchedTrianglesNeighboursOnceItsVerticesAreDone) {
  FilledGrid g = snapped_grid();  // off the symmetry line: the curtain cuts many patch edges
  ASSERT_GE(g.state.on_guide.size(), 3u);
  const VertexHandle first(g.state.on_guide.begin()->first);
  FaceHandle touched;
  for (const FaceHandle f : g.mesh.vf_range(first))
    if (std::find(g.state.patch.begin(), g.state.patch.end(), f) != g.state.patch.end())
      touched = f;
  ASSERT_TRUE(touched.is_valid());
  std::set<int> own;
  for (const VertexHandle u : g.mesh.fv_range(touched))
    if (g.state.on_guide.count(u.idx())) own.insert(u.idx());
  const Vec3 proxy = g.mesh.point(first) + Vec3(0, 0, 0.01);
  PushOptions push;
  push.step = 0.2;
  std::set<int> moved;
  PushResult r;
  for (int i = 0; i < 500; ++i) {
    r = push_down(g.mesh, g.state, proxy, proxy - Vec3(0.1, 0, 0), touched, push);
    if (!r.moved) break;
    moved.insert(r.vertex.idx());
  }
  EXPECT_FALSE(r.moved);
  EXPECT_NE(r.why_not.find("already at the curve"), std::string::npos) << r.why_not;
  std::size_t neighbours = 0;
  for (const int u : moved) {
    EXPECT_NEAR(g.mesh.point(VertexHandle(u))[2], -0.5, 1e-9);  // each stopped at the curve
    if (!own.count(u)) ++neighbours;
  }
  EXPECT_GT(neighbours, 0u) << g.state.on_guide.size() << " curtain vertices, " << own.size()
                            << " on the touched triangle";
}

TEST(SmoothByNormalPropagation, BringsABumpBackToThePlaneOfItsSurroundings) {
  FilledGrid g = filled_grid();
  // Interior vertices: split every patch face at its centroid.
  const std::vector<FaceHandle> original = g.state.patch;
  for (const FaceHandle f : original) {
    Vec3 c(0, 0, 0);
    for (const VertexHandle v : g.mesh.fv_range(f)) c += g.mesh.point(v) / 3.0;
    const VertexHandle nv = g.mesh.split(f, c);
    for (const FaceHandle nf : g.mesh.vf_range(nv))
      if (std::find(g.state.patch.begin(), g.state.patch.end(), nf) == g.state.patch.end())
        g.state.patch.push_back(nf);
  }
  std::set<int> interior;
  for (const FaceHandle f : g.state.patch)
    for (const VertexHandle v : g.mesh.fv_range(f))
      if (!g.state.boundary.count(v.idx())) interior.insert(v.idx());
  ASSERT_FALSE(interior.empty());
  for (const int i : interior) {
    Vec3 p = g.mesh.point(VertexHandle(i));
    p[2] = 0.3 * std::sin(p[0] * 3.0) + 0.2;
    g.mesh.set_point(VertexHandle(i), p);
  }
  const SmoothReport r = smooth_by_normal_propagation(g.mesh, g.state);
  EXPECT_EQ(r.moved, interior.size());
  for (const int i : interior) EXPECT_NEAR(g.mesh.point(VertexHandle(i))[2], 0.0, 1e-9);
}

TEST(Sharpen, BothVariantsRestoreACubeEdgeFromPickedPoints) {
  const std::array<std::array<Vec3, 2>, 1> edge{{{Vec3(8, 2.2, 8), Vec3(8, 5.8, 8)}}};
  for (const SharpenMethod method : {SharpenMethod::PushDown, SharpenMethod::Split}) {
    Mesh mesh = build_mesh(testing::cube_with_hole(8, Vec3(8, 4, 8), 2.2)).mesh;
    const auto holes = find_holes(mesh).holes;
    ASSERT_EQ(holes.size(), 1u);
    // A fair (rounded) fill first, so that the edge is really missing.
    SharpenOptions options;
    options.method = method;
    options.fill.shape = PatchShape::Fair;
    // Picks on the edge, slightly off the surface (the operator's hand): snapped onto it.
    const HermitePoints picks{{8, 0.5, 8.01}, {8, 2, 8}, {8, 6, 8}, {8.02, 7.5, 8}};
    const SharpenResult r = sharpen_hole(mesh, holes[0], picks, options);
    ASSERT_TRUE(r.ok) << to_string(method) << ": " << r.failure;
    const auto triangles = face_triangles(mesh, r.patch);
    const double crease = segment_distance(edge, triangles, 0.01).max;
    EXPECT_LT(crease, 0.05) << to_string(method);
    EXPECT_TRUE(validate_mesh(mesh).is_clean()) << to_string(method);
    EXPECT_TRUE(find_holes(mesh).holes.empty()) << to_string(method);
    EXPECT_TRUE(find_face_intersections(mesh, r.patch).empty()) << to_string(method);
    if (method == SharpenMethod::PushDown) {
      EXPECT_GT(r.pushed, 0u);
    }
  }
}

// The same edge through a pinched hole (an island of the cut left touching the rim at one
// vertex): the picks name rim vertices of the pinched loop, and the split follows them in the
// disk left once the pinch is closed.
TEST(Sharpen, PickedEdgeThroughAPinchedHoleIsRestored) {
  const std::array<std::array<Vec3, 2>, 1> edge{{{Vec3(8, 2.2, 8), Vec3(8, 5.8, 8)}}};
  Mesh mesh = build_mesh(testing::cut_leaving_an_island(testing::cube(8), Vec3(8, 4, 8), 2.2)).mesh;
  const auto holes = find_holes(mesh).holes;
  ASSERT_EQ(holes.size(), 1u);
  ASSERT_EQ(holes[0].pinched_at.size(), 1u);
  SharpenOptions options;
  options.fill.shape = PatchShape::Fair;
  const SharpenResult r =
      sharpen_hole(mesh, holes[0], {{8, 0.5, 8}, {8, 2, 8}, {8, 6, 8}, {8, 7.5, 8}}, options);
  ASSERT_TRUE(r.ok) << r.failure;
  EXPECT_LT(segment_distance(edge, face_triangles(mesh, r.patch), 0.01).max, 0.05);
  EXPECT_TRUE(validate_mesh(mesh).is_clean());
  EXPECT_TRUE(find_holes(mesh).holes.empty());
  EXPECT_TRUE(find_face_intersections(mesh, r.patch).empty());
}

// After the push the rest of the patch still has the rounded fill's shape. Fairing each side
// of the curve on its own (the default finish) lays it back onto the cube's two faces; the
// thesis' smoothing (Algorithm VII) and no finish leave it farther off them.
TEST(Sharpen, FairFinishLaysEachSideOfTheEdgeOntoItsFace) {
  std::map<PushFinish, double> off_faces;
  for (const PushFinish finish : {PushFinish::Fair, PushFinish::Smooth, PushFinish::None}) {
    Mesh mesh = build_mesh(testing::cube_with_hole(8, Vec3(8, 4, 8), 2.2)).mesh;
    const auto holes = find_holes(mesh).holes;
    ASSERT_EQ(holes.size(), 1u);
    SharpenOptions options;
    options.method = SharpenMethod::PushDown;
    options.finish = finish;
    options.fill.shape = PatchShape::Fair;
    const SharpenResult r =
        sharpen_hole(mesh, holes[0], {{8, 0.5, 8}, {8, 2, 8}, {8, 6, 8}, {8, 7.5, 8}}, options);
    ASSERT_TRUE(r.ok) << to_string(finish) << ": " << r.failure;
    EXPECT_TRUE(r.finish.undone.empty()) << to_string(finish) << ": " << r.finish.undone;
    if (finish == PushFinish::Fair) {
      EXPECT_GT(r.finish.fairing.moved, 0u);
    }
    EXPECT_TRUE(validate_mesh(mesh).is_clean()) << to_string(finish);
    EXPECT_TRUE(find_face_intersections(mesh, r.patch).empty()) << to_string(finish);
    // Distance of the patch's vertices from the nearer of the faces x = 8 and z = 8.
    double worst = 0;
    for (const FaceHandle f : r.patch)
      for (const VertexHandle v : mesh.fv_range(f)) {
        const Vec3& p = mesh.point(v);
        worst = std::max(worst, std::min(std::abs(p[0] - 8), std::abs(p[2] - 8)));
      }
    off_faces[finish] = worst;
  }
  // Measured: fair 0.0018, smooth 0.28, none 0.17 (the cube's side is 8).
  const std::string all = "fair " + std::to_string(off_faces[PushFinish::Fair]) + ", smooth " +
                          std::to_string(off_faces[PushFinish::Smooth]) + ", none " +
                          std::to_string(off_faces[PushFinish::None]);
  EXPECT_LT(off_faces[PushFinish::Fair], 0.01) << all;
  EXPECT_LT(off_faces[PushFinish::Fair], 0.1 * off_faces[PushFinish::None]) << all;
  EXPECT_LT(off_faces[PushFinish::Fair], 0.1 * off_faces[PushFinish::Smooth]) << all;
}

// A box corner cut away: three creases enter the hole and meet inside it, which the thesis'
// one curve P1..P4 cannot follow. Picked on each crease (a point away from the hole and one at
// the rim), they are extended to their common point, the cube's corner, and the hole is filled
// split along them: every new vertex lies on one of the three faces, the corner is a vertex.
TEST(Sharpen, ThreeCreasesPickedMeetAtTheCubeCorner) {
  Mesh mesh = build_mesh(testing::cube_with_hole(8, Vec3(8, 8, 8), 2.5)).mesh;
  const auto holes = find_holes(mesh).holes;
  ASSERT_EQ(holes.size(), 1u);
  PickedCreases picked;
  // On the edges along y, x and z towards the corner (8, 8, 8); the rim picks a little off.
  picked.corner = {{Vec3(8, 3.5, 8), Vec3(8, 5.6, 7.95)},
                   {Vec3(3.5, 8, 8), Vec3(5.6, 8.02, 8)},
                   {Vec3(8, 8, 3.5), Vec3(7.9, 8, 5.6)}};
  const SharpenResult r = sharpen_creases(mesh, holes[0], picked);
  ASSERT_TRUE(r.ok) << r.failure;
  EXPECT_EQ(r.crease_tangents_taken, 3);
  ASSERT_TRUE(r.corner);
  EXPECT_LT((*r.corner - Vec3(8, 8, 8)).norm(), 1e-9);
  double off_faces = 0;
  bool corner_vertex = false;
  for (const FaceHandle f : r.patch)
    for (const VertexHandle v : mesh.fv_range(f)) {
      const Vec3& p = mesh.point(v);
      off_faces = std::max(off_faces,
                           std::min({std::abs(p[0] - 8), std::abs(p[1] - 8), std::abs(p[2] - 8)}));
      corner_vertex = corner_vertex || (p - Vec3(8, 8, 8)).norm() < 1e-9;
    }
  EXPECT_LT(off_faces, 1e-9);
  EXPECT_TRUE(corner_vertex);
  EXPECT_TRUE(validate_mesh(mesh).is_clean());
  EXPECT_TRUE(find_holes(mesh).holes.empty());
  EXPECT_TRUE(find_face_intersections(mesh, r.patch).empty());
}

// Picks sharpen_creases refuses, with the reason: too few creases for a corner, two creases
// reaching the rim at one vertex, the push-down method, a pick far off the surface, and
// creases whose tangent lines do not meet.
TEST(Sharpen, CreasePicksThatMakeNoCornerAreRefusedWithTheReason) {
  const Mesh cube = build_mesh(testing::cube_with_hole(8, Vec3(8, 4, 8), 2.2)).mesh;
  const auto holes = find_holes(cube).holes;
  ASSERT_EQ(holes.size(), 1u);
  const auto refusal = [&](const PickedCreases& picked, const SharpenOptions& options = {}) {
    Mesh mesh = cube;
    const SharpenResult r = sharpen_creases(mesh, holes[0], picked, options);
    EXPECT_FALSE(r.ok);
    EXPECT_EQ(mesh.n_faces(), cube.n_faces());  // nothing added
    return r.failure;
  };
  const CreasePick edge_low{Vec3(8, 0.5, 8), Vec3(8, 2, 8)};
  const CreasePick edge_high{Vec3(8, 7.5, 8), Vec3(8, 6, 8)};
  PickedCreases two;
  two.corner = {edge_low, edge_high};
  EXPECT_NE(refusal(two).find("three or more creases"), std::string::npos);
  PickedCreases same_vertex;
  same_vertex.corner = {edge_low, edge_high, {Vec3(8, 0.5, 7.9), Vec3(8, 2.05, 8)}};
  EXPECT_NE(refusal(same_vertex).find("another pick took"), std::string::npos);
  PickedCreases curve;
  curve.curves = {{Vec3(8, 0.5, 8), Vec3(8, 2, 8), Vec3(8, 6, 8), Vec3(8, 7.5, 8)}};
  SharpenOptions push;
  push.method = SharpenMethod::PushDown;
  EXPECT_NE(refusal(curve, push).find("split variant only"), std::string::npos);
  PickedCreases far = curve;
  far.curves[0].p4 = Vec3(8, 400, 8);
  EXPECT_NE(refusal(far).find("P4"), std::string::npos);
  // The edge's two ends head towards each other, and a third crease from the rim on the face
  // x = 8 runs parallel to them, 2 below: no common point within a tenth of the hole's diameter.
  PickedCreases parallel;
  parallel.corner = {edge_low, edge_high, {Vec3(8, 0.5, 6), Vec3(8, 2, 6)}};
  EXPECT_NE(refusal(parallel).find("do not meet"), std::string::npos);
}

TEST(Sharpen, RefusesPicksAwayFromTheHole) {
  Mesh mesh = build_mesh(testing::cube_with_hole(8, Vec3(8, 4, 8), 2.2)).mesh;
  const auto holes = find_holes(mesh).holes;
  const std::size_t faces = mesh.n_faces();
  const SharpenResult far =
      sharpen_hole(mesh, holes[0], {{8, 0.5, 80}, {8, 2, 8}, {8, 6, 8}, {8, 7.5, 8}});
  EXPECT_FALSE(far.ok);
  EXPECT_NE(far.failure.find("P1"), std::string::npos) << far.failure;
  const SharpenResult same =
      sharpen_hole(mesh, holes[0], {{8, 0.5, 8}, {8, 2, 8}, {8, 2, 8}, {8, 7.5, 8}});
  EXPECT_FALSE(same.ok);
  mesh.garbage_collection();
  EXPECT_EQ(mesh.n_faces(), faces);
}

}  // namespace
}  // namespace touchmend::geometry
