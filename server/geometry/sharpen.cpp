#include "server/geometry/sharpen.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <fmt/format.h>

#include "server/geometry/bvh.h"
#include "server/geometry/mesh_intersections.h"
#include "server/geometry/patch_quality.h"
#include "server/geometry/sharp_edges.h"

namespace touchmend::geometry {
namespace {

//! Closest point on the faces around the hole (the thesis warns that a pick on a badly oriented
//! triangle biases the curve, seed 000 §5.1: the picks are put on the surface first).
struct SurfaceSnapper {
  std::vector<TrianglePoints> triangles;
  TriangleBvh bvh;
  SurfaceSnapper(const Mesh& mesh, const Hole& hole, double radius) {
    Box3 box;
    for (const VertexHandle v : hole.loop) {
      const Vec3& p = mesh.point(v);
      box.extend(Eigen::Vector3d(p[0], p[1], p[2]));
    }
    box.min().array() -= radius;
    box.max().array() += radius;
    for (const FaceHandle f : faces_in_box(mesh, box, max_edge_length(mesh))) {
      TrianglePoints t;
      int k = 0;
      for (const VertexHandle v : mesh.fv_range(f))
        t[static_cast<std::size_t>(k++)] = mesh.point(v);
      triangles.push_back(t);
    }
    bvh = TriangleBvh(triangles);
  }
  std::optional<Vec3> snap(const Vec3& p, double max_distance) const {
    if (triangles.empty()) return std::nullopt;
    const TriangleBvh::Closest c = bvh.closest_point(p);
    if (!c.found || std::sqrt(c.distance2) > max_distance) return std::nullopt;
    return c.point;
  }
};

std::size_t nearest_loop_index(const Mesh& mesh, const Hole& hole, const Vec3& p) {
  std::size_t best = 0;
  double best_d = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < hole.loop.size(); ++i) {
    const double d = (mesh.point(hole.loop[i]) - p).sqrnorm();
    if (d < best_d) {
      best_d = d;
      best = i;
    }
  }
  return best;
}

//! \p q on the surface around \p hole (the nearest point), or a failure naming the pick.
std::optional<Vec3> snap_pick(const SurfaceSnapper& snapper, const Hole& hole, const Vec3& q,
                              const std::string& name, const SharpenOptions& options,
                              double diameter, std::string& failure) {
  if (!std::isfinite(q[0]) || !std::isfinite(q[1]) || !std::isfinite(q[2])) {
    failure = name + " is not a finite point";
    return std::nullopt;
  }
  const auto snapped = snapper.snap(q, options.max_pick_distance * diameter);
  if (!snapped)
    failure = fmt::format(
        "{} ({:.6g}, {:.6g}, {:.6g}) is not on the surface around hole {} (farther than {} hole "
        "diameters)",
        name, q[0], q[1], q[2], hole.id, options.max_pick_distance);
  return snapped;
}

//! The hole filled split along the curves of \p plan (the split variant's last step).
void fill_split(Mesh& mesh, const Hole& hole, const HoleCreasePlan& plan,
                const SharpenOptions& options, SharpenResult& result) {
  FillOptions fill = options.fill;
  fill.explicit_creases = plan;
  fill.methods = {FillMethod::CreaseSplit};
  result.fill = fill_hole(mesh, hole, fill);
  if (!result.fill.filled) {
    result.failure = "the hole could not be filled along the curves: " + result.fill.reason;
    return;
  }
  result.patch = result.fill.new_faces;
  result.ok = true;
}

//! The crease from rim vertex \p at that \p pick lies on, its tangent pointing towards the pick
//! and its bend (crease_shape_towards with the options' angle and tolerance and the automatic
//! plan's fit length, so a pair picked on the creases it pairs gets its curve).
std::optional<CreaseShape> picked_crease_shape(const Mesh& mesh, VertexHandle at, const Vec3& pick,
                                               double perimeter, double mean_edge_length,
                                               const SharpenOptions& options) {
  if (!at.is_valid()) return std::nullopt;
  return crease_shape_towards(
      mesh, at, pick, options.crease_angle_deg, options.crease_pick_tolerance * mean_edge_length,
      crease_fit_length(perimeter, mean_edge_length, CreaseOptions{}.fit_length));
}

//! The tangent of picked_crease_shape.
std::optional<Vec3> crease_direction(const Mesh& mesh, VertexHandle at, const Vec3& pick,
                                     double perimeter, double mean_edge_length,
                                     const SharpenOptions& options) {
  const auto shape = picked_crease_shape(mesh, at, pick, perimeter, mean_edge_length, options);
  if (!shape) return std::nullopt;
  return shape->tangent;
}

//! The circular arc that the creases picked at rim vertices \p from (towards \p pick_from) and
//! \p to (towards \p pick_to) both continue into the hole, when both are curved alike
//! (crease_arc_between with the automatic plan's limits; an operator who picks both ends of one
//! crease vouches for the pairing, so the looser angle applies). None for straight creases, or
//! when no crease leads to a pick.
std::optional<CreaseArc> picked_crease_arc(const Mesh& mesh, const Hole& hole, std::size_t from,
                                           const Vec3& pick_from, std::size_t to,
                                           const Vec3& pick_to, const SharpenOptions& options) {
  const CreaseOptions& plan = options.fill.creases;
  const auto crossing = [&](std::size_t loop_index,
                            const Vec3& pick) -> std::optional<CreaseCrossing> {
    const auto shape = picked_crease_shape(mesh, hole.loop[loop_index], pick, hole.perimeter,
                                           hole.mean_edge_length, options);
    if (!shape) return std::nullopt;
    CreaseCrossing c;
    c.loop_index = loop_index;
    c.vertex = hole.loop[loop_index];
    c.position = mesh.point(c.vertex);
    c.inward = -shape->tangent;
    c.curvature = shape->curvature;
    c.bend_inward = -shape->bend_tangent;
    c.near_rim = shape->near_rim;
    c.rim_run = shape->rim_run;
    return c;
  };
  const auto a = crossing(from, pick_from);
  const auto b = crossing(to, pick_to);
  if (!a || !b) return std::nullopt;
  return crease_arc_between(*a, *b, min_arc_turn_deg(plan, *a, *b), plan.loose_pair_angle_deg,
                            plan.arc_curvature_factor);
}

//! take_crease_tangents on the rim of \p hole (loop indices of P2's and P3's vertices); the
//! picks unchanged with chord tangents.
CreaseTangentPicks take_hole_crease_tangents(const Mesh& mesh, const Hole& hole,
                                             std::optional<std::size_t> start,
                                             std::optional<std::size_t> end,
                                             const SharpenOptions& options,
                                             const HermitePoints& picks) {
  if (options.tangents != PickTangents::Crease) return {picks};
  return take_crease_tangents(mesh, picks, start ? hole.loop[*start] : VertexHandle(),
                              end ? hole.loop[*end] : VertexHandle(), hole.perimeter,
                              hole.mean_edge_length, options);
}

}  // namespace

CreaseTangentPicks take_crease_tangents(const Mesh& mesh, const HermitePoints& picks,
                                        VertexHandle at_p2, VertexHandle at_p3, double perimeter,
                                        double mean_edge_length, const SharpenOptions& options) {
  CreaseTangentPicks out{picks};
  HermitePoints& p = out.points;
  // P1 moves onto the tangent line at P2 at its own distance, P4 likewise at P3.
  const auto take = [&](VertexHandle at, const Vec3& rim, Vec3& far) {
    const auto t = crease_direction(mesh, at, far, perimeter, mean_edge_length, options);
    if (t) far = rim + (far - rim).norm() * *t;
    return t.has_value();
  };
  out.start = take(at_p2, p.p2, p.p1);
  out.end = take(at_p3, p.p3, p.p4);
  return out;
}

const char* to_string(PickTangents tangents) {
  return tangents == PickTangents::Crease ? "crease" : "chord";
}

bool parse_pick_tangents(const std::string& text, PickTangents& out) {
  if (text == "crease") {
    out = PickTangents::Crease;
    return true;
  }
  if (text == "chord") {
    out = PickTangents::Chord;
    return true;
  }
  return false;
}

const char* to_string(SharpenMethod method) {
  return method == SharpenMethod::Split ? "split" : "push-down";
}

SharpenResult sharpen_hole(Mesh& mesh, const Hole& hole, const HermitePoints& picks,
                           const SharpenOptions& options) {
  if (options.method == SharpenMethod::Split) {
    PickedCreases picked;
    picked.curves = {picks};
    return sharpen_creases(mesh, hole, picked, options);
  }
  SharpenResult result;
  const double diameter = std::max(hole.perimeter / std::numbers::pi, 1e-300);
  const double tolerance = 1e-9 * diameter;
  const SurfaceSnapper snapper(mesh, hole, options.max_pick_distance * diameter);
  HermitePoints p;
  const Vec3* in[4] = {&picks.p1, &picks.p2, &picks.p3, &picks.p4};
  Vec3* out[4] = {&p.p1, &p.p2, &p.p3, &p.p4};
  for (int i = 0; i < 4; ++i) {
    const auto snapped = snap_pick(snapper, hole, *in[i], fmt::format("P{}", i + 1), options,
                                   diameter, result.failure);
    if (!snapped) return result;
    *out[i] = *snapped;
  }

  // P2 and P3 stay where they were picked; a crease's tangent is taken where one reaches the
  // rim next to them.
  const auto rim_vertex = [&](const Vec3& q) -> std::optional<std::size_t> {
    const std::size_t i = nearest_loop_index(mesh, hole, q);
    if ((mesh.point(hole.loop[i]) - q).norm() <=
        options.crease_pick_tolerance * hole.mean_edge_length)
      return i;
    return std::nullopt;
  };
  const CreaseTangentPicks ends =
      take_hole_crease_tangents(mesh, hole, rim_vertex(p.p2), rim_vertex(p.p3), options, p);
  p = ends.points;
  result.crease_tangent_start = ends.start;
  result.crease_tangent_end = ends.end;
  const HermiteCurveResult curve = make_hermite_curve(p, options.hermite, tolerance);
  if (!curve.curve) {
    result.failure = curve.failure;
    return result;
  }
  result.points = p;
  // The picks define the crease: the first fill must not split the hole along creases it
  // finds itself, or the curve would already be in the patch with nothing left to push.
  FillOptions plain = options.fill;
  plain.sharp = SharpMode::Off;
  result.fill = fill_hole(mesh, hole, plain);
  if (!result.fill.filled) {
    result.failure = "the hole could not be filled: " + result.fill.reason;
    return result;
  }
  SharpEdgeState state;
  state.patch = result.fill.new_faces;
  for (const VertexHandle v : hole.loop) state.boundary.insert(v.idx());
  // The curtain must cut every patch triangle above and below the curve (ALGORITHMS.md §3.2).
  const Vec3 normal = hole.is_simple ? hole.reference_normal : hole.normal;
  double reach = 0;
  for (const FaceHandle f : state.patch)
    for (const VertexHandle v : mesh.fv_range(f))
      reach = std::max(reach, std::abs(OpenMesh::dot(mesh.point(v) - p.p2, normal)));
  state.guide = make_guide_surface(*curve.curve, normal, hole.mean_edge_length,
                                   std::max(diameter, 3 * reach));
  result.snap = snap_to_guide(mesh, state, options.snap);
  // The caller asked for a sharp edge, not a plain fill: a refusal leaves the hole as it was.
  const auto refuse = [&](std::string why, const std::vector<FaceHandle>& patch) {
    result.failure = std::move(why);
    for (const FaceHandle f : patch)
      if (!mesh.status(f).deleted()) mesh.delete_face(f, true);
    return result;
  };
  if (state.on_guide.empty())
    return refuse(
        "the Hermite curve does not cross the filled patch (seen along the hole normal): pick P2 "
        "and P3 on the hole's rim where the crease meets it",
        state.patch);
  PushOptions push;
  push.depth = options.depth;
  result.pushed = push_all(mesh, state, push);
  result.guide = state.guide;
  result.patch.clear();
  for (const FaceHandle f : state.patch)
    if (!mesh.status(f).deleted()) result.patch.push_back(f);
  // The finish only shapes the free vertices; if it fails or folds the patch into the mesh it
  // is undone and the pushed patch kept: the crease the operator asked for is there either way.
  result.finish = finish_push(mesh, state, options.finish, options.fill.check_intersections);
  // A finish that was kept was checked with the pushes in place; otherwise check the pushes.
  const bool checked = options.finish != PushFinish::None && result.finish.undone.empty();
  if (options.fill.check_intersections && !checked &&
      !find_face_intersections(mesh, result.patch, 1, max_edge_length(mesh)).empty())
    return refuse(
        "the retained edge makes the patch intersect the mesh (check the picked points and the "
        "depth)",
        result.patch);
  // Two curtain vertices with nearly the same place along the curve end at nearly the same
  // point once pushed onto it, and the triangle between them and a third vertex is a needle
  // (random picks with chord tangents and k of 2.7-4.6: 2 of about 2,400 push-downs, 0.004° and
  // 0.03°). Refused like an intersection; the split variant does not push.
  if (const double worst = min_angle_deg(mesh, result.patch); worst < kDegenerateAngleDeg)
    return refuse(fmt::format("the retained edge leaves a degenerate triangle ({:.3f}°): pick "
                              "the points again, change k, or use the split variant",
                              worst),
                  result.patch);
  result.ok = true;
  return result;
}

SharpenResult sharpen_creases(Mesh& mesh, const Hole& hole, const PickedCreases& picked,
                              const SharpenOptions& options) {
  SharpenResult result;
  if (picked.curves.empty() && picked.corner.empty()) {
    result.failure = "no creases picked";
    return result;
  }
  if (!picked.corner.empty() && picked.corner.size() < 3) {
    result.failure = fmt::format(
        "a corner needs three or more creases (two points each), {} given: for one crease "
        "through the hole pick P1..P4",
        picked.corner.size());
    return result;
  }
  if (options.method != SharpenMethod::Split) {
    result.failure = "several curves or a corner are retained by the split variant only";
    return result;
  }
  const double diameter = std::max(hole.perimeter / std::numbers::pi, 1e-300);
  const double tolerance = 1e-9 * diameter;
  const SurfaceSnapper snapper(mesh, hole, options.max_pick_distance * diameter);
  HoleCreasePlan plan;
  // A crossing at the boundary vertex nearest \p rim; one per vertex.
  const auto cross_at = [&](const Vec3& rim,
                            const std::string& name) -> std::optional<std::size_t> {
    CreaseCrossing c;
    c.loop_index = nearest_loop_index(mesh, hole, rim);
    for (const CreaseCrossing& other : plan.crossings)
      if (other.loop_index == c.loop_index) {
        result.failure = fmt::format(
            "{} is nearest to a boundary vertex another pick took (loop "
            "index {}): each crease meets the rim at its own vertex",
            name, c.loop_index);
        return std::nullopt;
      }
    c.vertex = hole.loop[c.loop_index];
    c.position = mesh.point(c.vertex);
    plan.crossings.push_back(c);
    return plan.crossings.size() - 1;
  };
  for (std::size_t k = 0; k < picked.curves.size(); ++k) {
    const std::string curve_name =
        picked.curves.size() > 1 ? fmt::format("curve {}'s ", k + 1) : std::string();
    HermitePoints p;
    const Vec3* in[4] = {&picked.curves[k].p1, &picked.curves[k].p2, &picked.curves[k].p3,
                         &picked.curves[k].p4};
    Vec3* out[4] = {&p.p1, &p.p2, &p.p3, &p.p4};
    for (int i = 0; i < 4; ++i) {
      const auto snapped = snap_pick(snapper, hole, *in[i], fmt::format("{}P{}", curve_name, i + 1),
                                     options, diameter, result.failure);
      if (!snapped) return result;
      *out[i] = *snapped;
    }
    // The curve must end on the boundary: P2 and P3 go to their nearest boundary vertices.
    const auto a = cross_at(p.p2, curve_name + "P2");
    if (!a) return result;
    const auto b = cross_at(p.p3, curve_name + "P3");
    if (!b) return result;
    const std::size_t i2 = plan.crossings[*a].loop_index, i3 = plan.crossings[*b].loop_index;
    p.p2 = plan.crossings[*a].position;
    p.p3 = plan.crossings[*b].position;
    const HermitePoints snapped = p;
    const CreaseTangentPicks ends = take_hole_crease_tangents(mesh, hole, i2, i3, options, p);
    p = ends.points;
    result.crease_tangents_taken += int{ends.start} + int{ends.end};
    const HermiteCurveResult curve = make_hermite_curve(p, options.hermite, tolerance);
    if (!curve.curve) {
      result.failure = curve_name + curve.failure;
      return result;
    }
    // Picks on both ends of a ring (a bore's rim): the arc both creases continue, which no
    // Hermite curve from four points can follow past a half turn.
    std::optional<CreaseArc> arc;
    if (options.tangents == PickTangents::Crease && ends.start && ends.end)
      arc = picked_crease_arc(mesh, hole, i2, snapped.p1, i3, snapped.p4, options);
    if (arc) ++result.arcs;
    plan.curves.push_back({*a, *b, 0, p, *curve.curve, arc});
    if (k == 0) {
      result.points = p;
      result.crease_tangent_start = ends.start;
      result.crease_tangent_end = ends.end;
    }
  }
  std::vector<std::size_t> corner_crossings;
  for (std::size_t k = 0; k < picked.corner.size(); ++k) {
    const auto far =
        snap_pick(snapper, hole, picked.corner[k].far, fmt::format("crease {}'s far point", k + 1),
                  options, diameter, result.failure);
    if (!far) return result;
    const auto rim =
        snap_pick(snapper, hole, picked.corner[k].rim, fmt::format("crease {}'s rim point", k + 1),
                  options, diameter, result.failure);
    if (!rim) return result;
    const auto index = cross_at(*rim, fmt::format("crease {}'s rim point", k + 1));
    if (!index) return result;
    CreaseCrossing& c = plan.crossings[*index];
    const double reach = (*far - c.position).norm();
    std::optional<Vec3> outward;
    if (options.tangents == PickTangents::Crease) {
      // The crease's bend too: creases that curve into their corner meet where they bend to
      // (join_at_corners), not where their tangent lines cross.
      if (const auto shape = picked_crease_shape(mesh, c.vertex, *far, hole.perimeter,
                                                 hole.mean_edge_length, options)) {
        outward = shape->tangent;
        c.curvature = shape->curvature;
        c.bend_inward = -shape->bend_tangent;
      }
    }
    if (outward) {
      ++result.crease_tangents_taken;
    } else if (reach > tolerance) {
      outward = (*far - c.position) / reach;
    } else {
      result.failure = fmt::format("crease {}'s two points meet at one boundary vertex", k + 1);
      return result;
    }
    c.inward = -*outward;
    c.far_point = c.position + reach * *outward;
    c.on_crease = *far;
    corner_crossings.push_back(*index);
  }
  if (!corner_crossings.empty()) {
    const double line_tolerance = options.fill.creases.corner_tolerance * diameter;
    if (!join_at_corners(plan, mesh, hole, corner_crossings, line_tolerance,
                         options.fill.creases.two_corner_gain, options.hermite, tolerance,
                         [](const Vec3&) { return true; })) {
      result.failure = fmt::format(
          "the corner's creases do not meet: their tangent lines into the hole pass no common "
          "point ahead of every crease within {:.3g} ({} hole diameters)",
          line_tolerance, options.fill.creases.corner_tolerance);
      return result;
    }
    result.corner = plan.corners.front();
  }
  plan.summary =
      fmt::format("{} picked curve{}{}", plan.curves.size(), plan.curves.size() == 1 ? "" : "s",
                  meeting_at_corners(plan.corners.size()));
  fill_split(mesh, hole, plan, options, result);
  return result;
}

std::string push_down_summary(const SharpenResult& result, PushFinish finish) {
  std::string text = fmt::format("{} snapped, {} split, {} pushed", result.snap.moved,
                                 result.snap.splits, result.pushed);
  const PushFinishReport& f = result.finish;
  if (!f.undone.empty())
    return text + fmt::format(", {} undone: {}",
                              finish == PushFinish::Smooth ? "smoothing" : "fairing", f.undone);
  if (finish == PushFinish::Smooth) return text + fmt::format(", {} smoothed", f.smooth.moved);
  if (finish == PushFinish::Fair) return text + fmt::format(", {} faired", f.fairing.moved);
  return text;
}

std::string tangents_summary(bool start, bool end, PickTangents tangents) {
  if (tangents == PickTangents::Chord) return "chord tangents";
  if (start && end) return "tangents of the crease at both ends";
  if (start) return "tangent of the crease at P2, the chord at P3 (P4 is on no crease from P3)";
  if (end) return "tangent of the crease at P3, the chord at P2 (P1 is on no crease from P2)";
  return "chord tangents (P1 and P4 are on no crease that reaches the rim at P2 and P3)";
}

std::string creases_summary(const SharpenResult& result, const PickedCreases& picked,
                            PickTangents tangents) {
  const std::size_t curves = picked.curves.size(), creases = picked.corner.size();
  std::string text;
  if (curves > 0) text = fmt::format("{} curve{}", curves, curves == 1 ? "" : "s");
  if (creases > 0)
    text += fmt::format("{}{} creases meeting at a corner", text.empty() ? "" : " and ", creases);
  if (result.corner)
    text += fmt::format(" ({:.6g}, {:.6g}, {:.6g})", (*result.corner)[0], (*result.corner)[1],
                        (*result.corner)[2]);
  if (tangents == PickTangents::Chord) return text + "; chord tangents";
  return text + fmt::format("; {} of {} along their crease's tangent", result.crease_tangents_taken,
                            2 * curves + creases);
}

}  // namespace touchmend::geometry
