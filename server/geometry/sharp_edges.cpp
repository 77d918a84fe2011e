#include "server/geometry/sharp_edges.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <initializer_list>
#include <limits>
#include <map>
#include <numbers>
#include <set>
#include <utility>

#include <Eigen/Dense>
#include <fmt/format.h>

#include "server/geometry/face_normals.h"
#include "server/geometry/intersection.h"
#include "server/geometry/liepa_triangulation.h"
#include "server/geometry/planar_triangulation.h"
#include "server/geometry/projection.h"

namespace touchmend::geometry {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;
//! The share of the tangent's fit length over which a crease's curvature is fitted (at least
//! three edges): couplingdown_sharp #1's arcs measure 0.68-0.9 of their curvature so, 0.29-0.68
//! over the whole length.
constexpr double kCurvatureFitShare = 0.3;
//! The bend fit stops where the crease has turned by a quarter turn: a parabola cannot follow a
//! ring further, and fitted over a small bore's whole rim (couplingdown_sml #2: a 160° stretch
//! of a 0.035 radius ring, 200° of it on the rim) it measured κ 5.2 where the ring has 28.6, so
//! the ring's ends were not joined by their arc (the crease 12.2‰ off once the regions' DP
//! weighed the curve edges as free; 2.8‰ with the arc).
constexpr double kMaxBendFitTurn = 0.5 * std::numbers::pi;

double dihedral_deg(FaceNormals& normals, HalfedgeHandle h) {
  const Mesh& mesh = normals.mesh();
  const Vec3 a = normals(mesh.face_handle(h));
  const Vec3 b = normals(mesh.face_handle(mesh.opposite_halfedge_handle(h)));
  return std::atan2(OpenMesh::cross(a, b).norm(), OpenMesh::dot(a, b)) / kDeg;
}

//! A crease threshold and its cosine, worked out once: is_sharp asks it of every edge around
//! each vertex a crease search visits.
struct SharpAngle {
  explicit SharpAngle(double threshold_deg)
      : degrees(threshold_deg), cosine(std::cos(threshold_deg * kDeg)) {}
  double degrees;
  double cosine;
};

//! Whether the dihedral angle at \p h's edge exceeds the threshold, compared as cosines (no
//! trigonometry per edge). A degenerate face has no normal and makes no crease.
bool is_sharp(FaceNormals& normals, HalfedgeHandle h, const SharpAngle& threshold) {
  const Mesh& mesh = normals.mesh();
  if (mesh.is_boundary(mesh.edge_handle(h))) return false;
  if (threshold.degrees >= 180.0) return false;
  const Vec3 a = normals(mesh.face_handle(h));
  const Vec3 b = normals(mesh.face_handle(mesh.opposite_halfedge_handle(h)));
  if (a.sqrnorm() == 0 || b.sqrnorm() == 0) return false;
  return OpenMesh::dot(a, b) < threshold.cosine;
}

//! Whether the edge of \p h is convex (a ridge): the face of \p h sees the far vertex of the
//! face across the edge below it.
bool folds_convex(FaceNormals& normals, HalfedgeHandle h) {
  const Mesh& mesh = normals.mesh();
  const VertexHandle across =
      mesh.to_vertex_handle(mesh.next_halfedge_handle(mesh.opposite_halfedge_handle(h)));
  return OpenMesh::dot(normals(mesh.face_handle(h)),
                       mesh.point(across) - mesh.point(mesh.from_vertex_handle(h))) < 0;
}

double angle_between(const Vec3& a, const Vec3& b) {
  return std::atan2(OpenMesh::cross(a, b).norm(), OpenMesh::dot(a, b));
}

//! A CAD part's surroundings: the median dihedral near the hole (median_dihedral_near) under
//! this, FillOptions::piecewise_planar_median_deg's default. The rules that only a part's exact
//! faces and corners justify are taken there alone (a scan bends a little at every edge).
constexpr double kCadMedianDihedralDeg = 1.0;

//! The point at \p t in [0, 1] along \p curve: its arc where it has one, else its Hermite curve.
Vec3 point_on(const CreaseCurve& curve, double t) {
  return curve.arc ? curve.arc->at(t) : curve.curve.at(t);
}

//! Follows the crease from the boundary vertex along \p first away from the hole: at each
//! vertex the sharp edge that continues straightest (turning less than 60°), until the length
//! budget, another boundary or the end of the crease.
std::vector<Vec3> trace_crease(FaceNormals& normals, HalfedgeHandle first,
                               const SharpAngle& threshold, double max_length) {
  const Mesh& mesh = normals.mesh();
  std::vector<Vec3> points{mesh.point(mesh.from_vertex_handle(first)),
                           mesh.point(mesh.to_vertex_handle(first))};
  double length = (points[1] - points[0]).norm();
  VertexHandle previous = mesh.from_vertex_handle(first);
  VertexHandle current = mesh.to_vertex_handle(first);
  // At most 64 points: a linear search beats a tree.
  std::vector<int> visited{previous.idx(), current.idx()};
  const auto was_visited = [&](VertexHandle v) {
    return std::find(visited.begin(), visited.end(), v.idx()) != visited.end();
  };
  while (length < max_length && points.size() < 64 && !mesh.is_boundary(current)) {
    const Vec3 direction = (mesh.point(current) - mesh.point(previous)).normalize_cond();
    HalfedgeHandle best;
    double best_cos = std::cos(60.0 * kDeg);
    for (const HalfedgeHandle h : mesh.voh_range(current)) {
      const VertexHandle w = mesh.to_vertex_handle(h);
      if (w == previous || was_visited(w) || !is_sharp(normals, h, threshold)) continue;
      const double c =
          OpenMesh::dot((mesh.point(w) - mesh.point(current)).normalize_cond(), direction);
      if (c > best_cos) {
        best_cos = c;
        best = h;
      }
    }
    if (!best.is_valid()) break;
    previous = current;
    current = mesh.to_vertex_handle(best);
    visited.push_back(current.idx());
    points.push_back(mesh.point(current));
    length += (points.back() - points[points.size() - 2]).norm();
  }
  return points;
}

struct CreaseFit {
  Vec3 tangent{0, 0, 0};        //!< unit, pointing along the polyline
  Vec3 curvature{0, 0, 0};      //!< κ·N (zero when the fit had too few points)
  std::size_t points_used = 0;  //!< polyline points after the first that the fit used
};

//! Tangent and curvature at points[0]: least-squares fit of p(s) = p0 + a s + b s² over the
//! points within \p fit_length of arc length (a is the tangent, 2b the second derivative), and
//! before the first edge that turns by more than \p max_turn (radians) from the first edge.
CreaseFit fit_crease(const std::vector<Vec3>& points, double fit_length, std::size_t min_points = 1,
                     double max_turn = std::numeric_limits<double>::infinity()) {
  double s = 0;
  const Vec3 first = points.size() > 1 ? (points[1] - points[0]).normalize_cond() : Vec3(0, 0, 0);
  const double min_cos = max_turn < std::numbers::pi ? std::cos(max_turn) : -2.0;
  Eigen::Matrix2d normal = Eigen::Matrix2d::Zero();
  Eigen::Matrix<double, 2, 3> rhs = Eigen::Matrix<double, 2, 3>::Zero();
  std::size_t used = 0;
  for (std::size_t i = 1; i < points.size(); ++i) {
    const Vec3 step = points[i] - points[i - 1];
    s += step.norm();
    const bool turned = OpenMesh::dot(step, first) < min_cos * step.norm();
    if ((s > fit_length || turned) && used >= min_points) break;
    const Vec3 d = points[i] - points[0];
    normal(0, 0) += s * s;
    normal(0, 1) += s * s * s;
    normal(1, 1) += s * s * s * s;
    for (int c = 0; c < 3; ++c) {
      rhs(0, c) += s * d[c];
      rhs(1, c) += s * s * d[c];
    }
    ++used;
  }
  CreaseFit fit;
  fit.points_used = used;
  Vec3 second(0, 0, 0);
  if (used >= 2) {
    normal(1, 0) = normal(0, 1);
    const Eigen::Matrix<double, 2, 3> ab = normal.ldlt().solve(rhs);
    fit.tangent = Vec3(ab(0, 0), ab(0, 1), ab(0, 2));
    second = 2.0 * Vec3(ab(1, 0), ab(1, 1), ab(1, 2));
  }
  const double speed = fit.tangent.norm();
  if (!(speed > 0) || !std::isfinite(speed) || !std::isfinite(second.norm())) {
    fit.tangent = points.size() > 1 ? points[1] - points[0] : Vec3(0, 0, 0);
    return {fit.tangent.normalize_cond(), Vec3(0, 0, 0), used};
  }
  fit.tangent /= speed;
  // The part of the acceleration across the tangent, per unit arc length squared.
  fit.curvature = (second - OpenMesh::dot(second, fit.tangent) * fit.tangent) / (speed * speed);
  return fit;
}

//! The crease's bend by the rim: tangent and curvature fitted over kCurvatureFitShare of \p
//! fit_length (at least three points), up to a quarter turn (kMaxBendFitTurn).
CreaseFit fit_bend(const std::vector<Vec3>& polyline, double fit_length) {
  return fit_crease(polyline, kCurvatureFitShare * fit_length, 3, kMaxBendFitTurn);
}

//! A traced crease's direction (fitted over \p fit_length) and its bend by the rim, which is
//! measured nearer the rim than the direction: over the whole length a bore's rim, a few edges
//! long, is averaged with the straight crease it runs into.
CreaseShape shape_of_crease(const std::vector<Vec3>& polyline, double fit_length) {
  const CreaseFit bend = fit_bend(polyline, fit_length);
  return {fit_crease(polyline, fit_length).tangent, bend.curvature, bend.tangent,
          std::vector<Vec3>(polyline.begin(),
                            polyline.begin() + static_cast<std::ptrdiff_t>(bend.points_used + 1))};
}

//! Whether \p q continues the crease traced as \p outward (outward[0] on the rim, the crease
//! beyond it): within a quarter of the shortest of the step, the crease's own last edge and
//! \p edge_length of where its tangent and curvature, fitted by the rim, carry it (a long rim
//! edge must not be taken for a continuation by chance).
bool continues_crease(const std::vector<Vec3>& outward, const Vec3& q, double fit_length,
                      double edge_length) {
  if (outward.size() < 2) return false;
  const CreaseFit fit = fit_bend(outward, fit_length);
  const Vec3& p = outward[0];
  const double s = (q - p).norm();
  const Vec3 predicted = p - s * fit.tangent + 0.5 * s * s * fit.curvature;
  const double own_edge = (outward[1] - outward[0]).norm();
  return (q - predicted).norm() <= 0.25 * std::min({s, own_edge, edge_length});
}

//! The angle at which direction \p d leaves the boundary vertex \p b, counter-clockwise from
//! the next boundary edge, and the hole's corner angle there, both in the tangent plane of the
//! surface at b (normal \p normal): a global projection distorts the angles at a cube corner.
std::pair<double, double> wedge_angles(const Vec3& normal, const Vec3& prev, const Vec3& b,
                                       const Vec3& next, const Vec3& d) {
  const ReferenceFrame frame = ReferenceFrame::from_normal(normal, b);
  const Point2 pa = frame.project(prev), pb = frame.project(b), pc = frame.project(next);
  const Point2 u = pc - pb;
  const Point2 d2(OpenMesh::dot(d, frame.e1), OpenMesh::dot(d, frame.e2));
  double phi = std::atan2(u.x() * d2.y() - u.y() * d2.x(), u.dot(d2));
  if (phi < 0) phi += 2 * std::numbers::pi;
  return {phi, interior_angle(pa, pb, pc)};
}

Vec3 vertex_normal(FaceNormals& normals, VertexHandle v) {
  Vec3 n(0, 0, 0);
  for (const FaceHandle f : normals.mesh().vf_range(v)) n += normals(f);
  return n.normalize_cond();
}

//! Point nearest (least squares) to the lines x = B_i + t d_i.
std::optional<Vec3> nearest_point_to_lines(const std::vector<Vec3>& origins,
                                           const std::vector<Vec3>& directions) {
  Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
  Eigen::Vector3d r = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < origins.size(); ++i) {
    const Eigen::Vector3d d(directions[i][0], directions[i][1], directions[i][2]);
    const Eigen::Vector3d o(origins[i][0], origins[i][1], origins[i][2]);
    const Eigen::Matrix3d p = Eigen::Matrix3d::Identity() - d * d.transpose();
    m += p;
    r += p * o;
  }
  // Nearly parallel lines have no well-defined nearest point.
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(m, Eigen::EigenvaluesOnly);
  const Eigen::Vector3d values = eigen.eigenvalues();  // ascending
  if (!(values(0) > 1e-6 * values(2))) return std::nullopt;
  const Eigen::Vector3d x = m.ldlt().solve(r);
  if (!x.allFinite()) return std::nullopt;
  return Vec3(x.x(), x.y(), x.z());
}

//! Where a point lies along \p arc: its angle from the start in [0, 2π) and its distance from
//! the arc's circle.
std::pair<double, double> arc_position(const CreaseArc& arc, const Vec3& p) {
  const Vec3 radial = (arc.start - arc.centre) / arc.radius;
  const Vec3 axis = OpenMesh::cross(radial, arc.start_direction);
  const Vec3 d = p - arc.centre;
  const double x = OpenMesh::dot(d, radial), y = OpenMesh::dot(d, arc.start_direction);
  double phi = std::atan2(y, x);
  if (phi < 0) phi += 2 * std::numbers::pi;
  const double off_circle = std::hypot(std::hypot(x, y) - arc.radius, OpenMesh::dot(d, axis));
  return {phi, off_circle};
}

//! The part of \p arc from angle \p from to angle \p to.
CreaseArc sub_arc(const CreaseArc& arc, double from, double to) {
  CreaseArc out = arc;
  const Vec3 radial = arc.start - arc.centre;
  out.start =
      arc.centre + std::cos(from) * radial + std::sin(from) * arc.radius * arc.start_direction;
  out.start_direction =
      -std::sin(from) * radial / arc.radius + std::cos(from) * arc.start_direction;
  out.angle = to - from;
  return out;
}

//! The stretches of \p arc that cross the hole: a ring may run along the rim for a while and cut
//! across the hole only for the rest (couplingdown_sml #2: a 315° arc between two crossings of
//! which 58% lies on the rim). Boundary vertices within a quarter of \p edge_length of the arc
//! cut it; of the pieces between consecutive cuts those whose middle is that near the rim too
//! run along it and are dropped, and a piece between two neighbouring boundary vertices is their
//! boundary edge. Returns (angle from, angle to, loop index from, loop index to) per piece.
struct ArcPiece {
  double from, to;
  std::size_t loop_from, loop_to;
};
std::vector<ArcPiece> arc_pieces_across(const CreaseArc& arc, std::size_t loop_from,
                                        std::size_t loop_to, const std::vector<Vec3>& rim,
                                        double edge_length) {
  const double near = 0.25 * edge_length;
  const std::size_t n = rim.size();
  std::vector<std::pair<double, std::size_t>> cuts{{0.0, loop_from}, {arc.angle, loop_to}};
  for (std::size_t i = 0; i < n; ++i) {
    if (i == loop_from || i == loop_to) continue;
    const auto [phi, off] = arc_position(arc, rim[i]);
    if (off <= near && phi > 0 && phi < arc.angle) cuts.emplace_back(phi, i);
  }
  std::sort(cuts.begin(), cuts.end());
  const auto near_rim = [&](const Vec3& q) {
    for (std::size_t i = 0; i < n; ++i)
      if (segment_segment_distance2(q, q, rim[i], rim[(i + 1) % n]) <= near * near) return true;
    return false;
  };
  std::vector<ArcPiece> pieces;
  for (std::size_t k = 0; k + 1 < cuts.size(); ++k) {
    const auto [a, i] = cuts[k];
    const auto [b, j] = cuts[k + 1];
    if (i == j || (i + 1) % n == j || (j + 1) % n == i) continue;
    if (near_rim(sub_arc(arc, a, b).at(0.5))) continue;
    pieces.push_back({a, b, i, j});
  }
  return pieces;
}

bool interleaved(std::size_t a, std::size_t b, std::size_t c, std::size_t d) {
  if (a > b) std::swap(a, b);
  if (c > d) std::swap(c, d);
  return (a < c && c < b && b < d) || (c < a && a < d && d < b);
}

}  // namespace

double crease_fit_length(double perimeter, double mean_edge_length, double fit_length) {
  return std::max(fit_length * perimeter / std::numbers::pi, 2.5 * mean_edge_length);
}

Vec3 CreaseArc::at(double t) const {
  const double phi = t * angle;
  return centre + std::cos(phi) * (start - centre) + std::sin(phi) * radius * start_direction;
}

double min_arc_turn_deg(const CreaseOptions& options, const CreaseCrossing& a,
                        const CreaseCrossing& b) {
  return a.rim_run > 0 || b.rim_run > 0 ? options.rim_run_min_arc_turn_deg
                                        : options.min_arc_turn_deg;
}

std::optional<CreaseArc> crease_arc_between(const CreaseCrossing& a, const CreaseCrossing& b,
                                            double min_turn_deg, double max_angle_deg,
                                            double curvature_factor, double* score) {
  const Vec3 chord = b.position - a.position;
  const double length = chord.norm();
  if (!(length > 0) || !(curvature_factor >= 1)) return std::nullopt;
  const Vec3 along = chord / length;
  // A circle leaves a at angle θ to the chord and arrives at b at θ on the other side: the
  // arrival is the departure mirrored about the chord, turned by 2θ. Both ends' measured angles
  // and the sides they bend to are averaged, so neither end's tangent is trusted over the other.
  const Vec3 depart = a.inward;
  const Vec3 arrive = -b.inward;
  const Vec3 mirrored = 2.0 * OpenMesh::dot(depart, along) * along - depart;
  const double mismatch = angle_between(mirrored, arrive);
  const Vec3 side = (depart - OpenMesh::dot(depart, along) * along) -
                    (arrive - OpenMesh::dot(arrive, along) * along);
  if (!(side.norm() > 1e-9)) return std::nullopt;
  const Vec3 up = Vec3(side).normalize();
  double theta = 0.5 * (angle_between(depart, along) + angle_between(arrive, along));
  // The tangents fix the plane and the way round; the circle itself is fitted to the creases'
  // points by the rim (a tangent fitted over a curved crease is biased towards its chord). In
  // the plane (along, up) with a at the origin, the centre is (L/2, -h): each point q gives
  // |q - M|² - L²/4 = 2h (q - M)·(-up), solved for h by least squares.
  {
    const Vec3 middle = 0.5 * (a.position + b.position);
    double ab = 0, bb = 0;
    for (const auto* crossing : {&a, &b})
      for (std::size_t i = 1; i < crossing->near_rim.size(); ++i) {
        const Vec3 q = crossing->near_rim[i] - middle;
        const Vec3 in_plane = OpenMesh::dot(q, along) * along + OpenMesh::dot(q, up) * up;
        const double lhs = in_plane.sqrnorm() - 0.25 * length * length;
        const double coefficient = -2.0 * OpenMesh::dot(q, up);
        ab += lhs * coefficient;
        bb += coefficient * coefficient;
      }
    // At least a point off the chord's line; otherwise the tangents' estimate stands.
    if (bb > 1e-12 * length * length) {
      const double h = ab / bb;
      const double fitted = std::atan2(0.5 * length, h);
      // Refined only within the tangents' agreement: the way round stays the tangents'.
      if (std::abs(fitted - theta) <= max_angle_deg * kDeg) theta = fitted;
    }
  }
  // Near a full turn the circle's size is ill-determined by the two ends (sin θ -> 0).
  if (2 * theta < min_turn_deg * kDeg || theta > 165 * kDeg || mismatch > max_angle_deg * kDeg)
    return std::nullopt;
  CreaseArc arc;
  arc.radius = length / (2 * std::sin(theta));
  arc.start = a.position;
  arc.start_direction = std::cos(theta) * along + std::sin(theta) * up;
  const Vec3 to_centre = std::sin(theta) * along - std::cos(theta) * up;
  arc.centre = a.position + arc.radius * to_centre;
  arc.angle = 2 * theta;
  // Each crease must bend like the arc: by its curvature, towards its centre.
  const double kappa = 1.0 / arc.radius;
  for (const auto& [crossing, normal] :
       {std::pair{&a, to_centre}, std::pair{&b, Vec3(arc.centre - b.position).normalize()}}) {
    const Vec3& k = crossing->curvature;
    if (!(k.norm() * curvature_factor >= kappa && k.norm() <= curvature_factor * kappa) ||
        !(OpenMesh::dot(k, normal) > 0.5 * k.norm()))
      return std::nullopt;
  }
  if (score) *score = mismatch;
  return arc;
}

std::optional<CreaseShape> crease_shape_towards(const Mesh& mesh, VertexHandle at, const Vec3& pick,
                                                double angle_deg, double tolerance,
                                                double fit_length) {
  if (!at.is_valid() || !std::isfinite(tolerance) || !(tolerance > 0)) return std::nullopt;
  const Vec3& origin = mesh.point(at);
  // Far enough to pass the pick; the trace ends earlier where the crease does.
  const double budget = std::max(1.5 * (pick - origin).norm() + tolerance, fit_length);
  const SharpAngle sharp(angle_deg);
  std::optional<CreaseShape> best;
  double best_distance2 = tolerance * tolerance;
  FaceNormals normals(mesh, 64);
  const auto distance2_to_pick = [&](const std::vector<Vec3>& polyline) {
    double d2 = std::numeric_limits<double>::infinity();
    for (std::size_t i = 1; i < polyline.size(); ++i)
      d2 = std::min(d2, segment_segment_distance2(polyline[i - 1], polyline[i], pick, pick));
    return d2;
  };
  // The creases leaving \p v, each prefixed by \p rim (the rim vertices from `at` up to v).
  const auto try_creases_from = [&](VertexHandle v, const std::vector<Vec3>& rim) {
    for (const HalfedgeHandle h : mesh.voh_range(v)) {
      if (!is_sharp(normals, h, sharp)) continue;
      std::vector<Vec3> polyline = trace_crease(normals, h, sharp, budget);
      const double distance2 = distance2_to_pick(polyline);
      if (!(distance2 <= best_distance2)) continue;
      if (rim.size() > 1) {
        // The crease reaches the rim at v and follows it back to `at`: each rim vertex must
        // continue it, as plan_hole_creases walks the rim.
        polyline.insert(polyline.begin(), rim.begin(), rim.end() - 1);
        bool follows = true;
        for (std::size_t k = rim.size() - 1; k-- > 0 && follows;)
          follows = continues_crease(
              {polyline.begin() + static_cast<std::ptrdiff_t>(k) + 1, polyline.end()}, polyline[k],
              fit_length, std::numeric_limits<double>::infinity());
        if (!follows) continue;
      }
      CreaseShape shape = shape_of_crease(polyline, fit_length);  // as plan_hole_creases does
      if (!(shape.tangent.norm() > 0)) continue;
      shape.rim_run = rim.size() - 1;
      best_distance2 = distance2;
      best = std::move(shape);
    }
  };
  try_creases_from(at, {origin});
  if (best || !mesh.is_boundary(at)) return best;
  // No crease leaves `at` towards the pick: one may reach the rim nearby and run along it to
  // `at`, where it leaves the rim into the hole (a ring along the rim). Walk the boundary both
  // ways, as far as the pick.
  HalfedgeHandle out;
  for (const HalfedgeHandle h : mesh.voh_range(at))
    if (mesh.is_boundary(h)) out = h;
  if (!out.is_valid()) return best;
  for (const bool forward : {true, false}) {
    std::vector<Vec3> rim{origin};
    HalfedgeHandle h = forward ? out : mesh.prev_halfedge_handle(out);
    double walked = 0;
    for (int steps = 0; steps < 64 && walked < budget; ++steps) {
      const VertexHandle v = forward ? mesh.to_vertex_handle(h) : mesh.from_vertex_handle(h);
      if (v == at) break;
      walked += (mesh.point(v) - rim.back()).norm();
      rim.push_back(mesh.point(v));
      try_creases_from(v, rim);
      if (best) return best;
      h = forward ? mesh.next_halfedge_handle(h) : mesh.prev_halfedge_handle(h);
    }
  }
  return best;
}

std::optional<Vec3> crease_tangent_towards(const Mesh& mesh, VertexHandle at, const Vec3& pick,
                                           double angle_deg, double tolerance, double fit_length) {
  const auto shape = crease_shape_towards(mesh, at, pick, angle_deg, tolerance, fit_length);
  if (!shape) return std::nullopt;
  return shape->tangent;
}

namespace {

//! The least-squares nearest point to the tangent lines of the creases of \p crossings.
std::optional<Vec3> nearest_to_tangent_lines(const HoleCreasePlan& plan,
                                             std::span<const std::size_t> crossings) {
  std::vector<Vec3> origins, directions;
  for (const std::size_t i : crossings) {
    origins.push_back(plan.crossings[i].position);
    directions.push_back(plan.crossings[i].inward);
  }
  return nearest_point_to_lines(origins, directions);
}

//! nearest_to_tangent_lines of \p crossings (two or more), if it lies ahead of every crossing
//! and within \p line_tolerance of every line.
std::optional<Vec3> corner_ahead_of(const HoleCreasePlan& plan,
                                    std::span<const std::size_t> crossings, double line_tolerance) {
  if (crossings.size() < 2) return std::nullopt;
  const std::optional<Vec3> corner = nearest_to_tangent_lines(plan, crossings);
  if (!corner) return std::nullopt;
  for (const std::size_t i : crossings) {
    const Vec3& origin = plan.crossings[i].position;
    const Vec3& direction = plan.crossings[i].inward;
    const Vec3 to_corner = *corner - origin;
    const double along = OpenMesh::dot(to_corner, direction);
    const double off_line = (to_corner - along * direction).norm();
    if (along <= 0 || off_line > line_tolerance) return std::nullopt;
  }
  return corner;
}

//! Curves whose nearest points all slide, each within this angle of the others' line, run side by
//! side: they meet at no point (meeting_point).
constexpr double kParallelCurvesDeg = 1.0;

//! A point's nearest point on one of the curves a corner is fitted to, and the unit direction in
//! which that nearest point slides as the point moves (the curve's tangent there); zero where it
//! is held (a crease or link clamped at its start).
struct CurveProjection {
  Vec3 point;
  Vec3 slide;
};

//! A bent crease continued as its circle turns at most this far (a crease that curves into a
//! corner turns by less; past it the circle would come back towards the rim).
constexpr double kMaxBentCreaseTurn = 2.0 * std::numbers::pi / 3.0;

//! The point nearest \p x on the crease of \p c continued into the hole with the bend fitted
//! at the rim: the circle from p along t with the fitted curvature κ (its osculating circle),
//! s ≥ 0, at most kMaxBentCreaseTurn round. t is the tangent of the same short fit as κ
//! (bend_inward): the tangent fitted over the whole fit length is the mean direction of a
//! curved crease's stretch, turned against its bend (couplingdown_sharp #2's top creases: 10°
//! off, which put their corner 0.012 from the truth; 0.0035 with the bend's own tangent). A
//! circle, not the parabola p + s·t + ½s²κ of the same bend: the two agree near the rim, but a
//! fandisk crease of radius 1.03 that curves 75° into its corner passes 0.26 from it as the
//! parabola and 0.02 as the circle.
CurveProjection project_on_bent_crease(const CreaseCrossing& c, const Vec3& x) {
  const Vec3 t = c.bend_inward.norm() > 0 ? c.bend_inward : c.inward;
  const Vec3 bend = c.curvature - OpenMesh::dot(c.curvature, t) * t;
  const double kappa = bend.norm();
  const Vec3 d = x - c.position;
  if (!(kappa * d.norm() > 1e-9)) {
    // Straight (or x at the rim): the tangent ray.
    const double along = OpenMesh::dot(d, t);
    if (along > 0) return {c.position + along * t, t};
    return {c.position, Vec3(0, 0, 0)};
  }
  const Vec3 towards_centre = bend / kappa;
  const double radius = 1.0 / kappa;
  // x's angle round the centre (p + radius·towards_centre) from p, in the circle's plane, the
  // way t turns; written from p, so a nearly straight crease's far centre costs no precision.
  const double angle = std::atan2(OpenMesh::dot(d, t), radius - OpenMesh::dot(d, towards_centre));
  const double turn = std::clamp(angle, 0.0, kMaxBentCreaseTurn);
  if (!(turn > 0)) return {c.position, Vec3(0, 0, 0)};
  const double half_sine = std::sin(0.5 * turn);
  const Vec3 point = c.position + radius * std::sin(turn) * t +
                     2.0 * radius * half_sine * half_sine * towards_centre;  // 1 - cos = 2 sin²
  // Held at the arc's end, as at its start: a point beyond either moves its projection nowhere.
  const Vec3 slide = angle < kMaxBentCreaseTurn
                         ? std::cos(turn) * t + std::sin(turn) * towards_centre
                         : Vec3(0, 0, 0);
  return {point, slide};
}

Vec3 nearest_on_bent_crease(const CreaseCrossing& c, const Vec3& x) {
  return project_on_bent_crease(c, x).point;
}

//! Whether every projection slides (none is held) and all their slides lie within
//! kParallelCurvesDeg of the first one's line.
bool slide_along_one_line(std::span<const CurveProjection> projections) {
  const double min_cos = std::cos(kParallelCurvesDeg * std::numbers::pi / 180.0);
  for (const CurveProjection& p : projections)
    if (!(p.slide.sqrnorm() > 0) ||
        !(std::abs(OpenMesh::dot(p.slide, projections.front().slide)) >= min_cos))
      return false;
  return true;
}

//! The point nearest \p x on the ray from \p origin along the unit \p direction.
CurveProjection project_on_ray(const Vec3& origin, const Vec3& direction, const Vec3& x) {
  const double along = OpenMesh::dot(x - origin, direction);
  if (along > 0) return {origin + along * direction, direction};
  return {origin, Vec3(0, 0, 0)};
}

//! The point where curves come closest: the minimum of the sum of squared distances to them,
//! from \p start; \p project(x, out) fills \p out with x's projections onto the curves. At that
//! point x is the mean of its own projections (the gradient, 2·Σ(x − P_i(x)), vanishes), which
//! alternating projections reach too, but linearly: 40 to over 100 rounds on couplingdown_sharp
//! #2's corners. Gauss-Newton steps, the point nearest the curves' tangent lines at the current
//! projections (a held projection counts as a point), reach it in a few rounds where the curves
//! nearly meet; a step that does not lower the sum is replaced by the mean of the projections,
//! which does. Stops once a round moves the point by less than 1e-12 of \p scale (at most 100
//! rounds). None where every curve slides along one line at the start (none held, the slides
//! within kParallelCurvesDeg of each other): creases that run side by side meet at no point,
//! the sum is all but constant along them, and the rounds would creep along them to where the
//! round limit stops them (couplingdown_sharp #2: two top creases 0.011 apart, 0.005° from
//! parallel, had their "corner" placed by that limit; no plan took it).
template <typename Project>
std::optional<Vec3> meeting_point(const Vec3& start, double scale, Project&& project) {
  std::vector<CurveProjection> at, next_at;
  const auto spread = [](const Vec3& x, const std::vector<CurveProjection>& projections) {
    double sum = 0;
    for (const CurveProjection& p : projections) sum += (x - p.point).sqrnorm();
    return sum;
  };
  const auto mean = [](const std::vector<CurveProjection>& projections) {
    Vec3 sum(0, 0, 0);
    for (const CurveProjection& p : projections) sum += p.point;
    return sum / static_cast<double>(projections.size());
  };
  const auto nearest_to_tangents =
      [](const std::vector<CurveProjection>& projections) -> std::optional<Vec3> {
    Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
    Eigen::Vector3d r = Eigen::Vector3d::Zero();
    for (const CurveProjection& p : projections) {
      const Eigen::Vector3d u(p.slide[0], p.slide[1], p.slide[2]);
      const Eigen::Matrix3d across = Eigen::Matrix3d::Identity() - u * u.transpose();
      m += across;
      r += across * Eigen::Vector3d(p.point[0], p.point[1], p.point[2]);
    }
    const Eigen::LDLT<Eigen::Matrix3d> ldlt(m);
    // Tangent lines all nearly parallel fix no point along them.
    if (!(ldlt.rcond() > 1e-9)) return std::nullopt;
    const Eigen::Vector3d y = ldlt.solve(r);
    if (!y.allFinite()) return std::nullopt;
    return Vec3(y.x(), y.y(), y.z());
  };
  Vec3 x = start;
  project(x, at);
  if (at.empty()) return std::nullopt;
  if (slide_along_one_line(at)) return std::nullopt;
  double sum = spread(x, at);
  const double settled = 1e-12 * scale;
  for (int round = 0; round < 100; ++round) {
    std::optional<Vec3> next = nearest_to_tangents(at);
    double next_sum = std::numeric_limits<double>::infinity();
    if (next) {
      project(*next, next_at);
      next_sum = spread(*next, next_at);
    }
    // Rounding leaves the sum noisy near the minimum: a step that raises it by less is taken.
    if (!(next_sum <= sum + 1e-14 * (sum + scale * scale))) {
      next = mean(at);
      project(*next, next_at);
      next_sum = spread(*next, next_at);
    }
    const bool done = (*next - x).norm() <= settled;
    x = *next;
    std::swap(at, next_at);
    sum = next_sum;
    if (done) break;
  }
  return x;
}

//! Where the bent creases (nearest_on_bent_crease) of \p crossings come closest to a common
//! point: meeting_point from \p start (the point nearest their tangent lines). A crease
//! that curves into a corner (couplingdown_sharp #2's top edges) misses it along its tangent
//! line by a third of the hole's radius.
std::optional<Vec3> corner_of_bent_creases(const HoleCreasePlan& plan,
                                           std::span<const std::size_t> crossings,
                                           const Vec3& start) {
  return meeting_point(start, (start - plan.crossings[crossings.front()].position).norm(),
                       [&](const Vec3& x, std::vector<CurveProjection>& out) {
                         out.clear();
                         for (const std::size_t i : crossings)
                           out.push_back(project_on_bent_crease(plan.crossings[i], x));
                       });
}

//! How far \p corner lies from the farthest of the bent creases of \p crossings.
double farthest_bent_crease(const HoleCreasePlan& plan, std::span<const std::size_t> crossings,
                            const Vec3& corner) {
  double worst = 0;
  for (const std::size_t i : crossings)
    worst = std::max(worst, (nearest_on_bent_crease(plan.crossings[i], corner) - corner).norm());
  return worst;
}

//! RunCorners: a bend is trusted from a crease traced over this many edges...
constexpr std::size_t kFittedBendEdges = 3;
//! ...whose other edges bend by at most this share of its angle.
constexpr double kFittedBendOtherRatio = 0.25;
//! RunCorners: the corner of clean creases may lie up to this many rim radii from the rim's
//! centroid (the rim's ball otherwise). A ball cut that takes the tip of a thin wing leaves a
//! belt around the wing, and the tip's corners stick out of it (fandisk: 1.27 rim radii). Measured
//! on the ball-cut bench, seeds 1-9: 1.5 fills the 4-crease holes of fandisk's wing tips along
//! two corners (20 fills closer, none farther); for every run, two hand cuts took corners of its
//! finger grooves as well (Hausdorff 31 -> 66 per mille).
constexpr double kTipReachRimRadii = 1.5;

//! The corners of the runs of creases contiguous along the loop, each worked out once (the two-
//! and three-corner searches try every split of the loop, and a run recurs in many splits): the
//! point nearest the run's tangent lines (corner_ahead_of), moved to where its bent creases
//! come closest (corner_of_bent_creases), if that is near the hole: within the rim's ball, or
//! for clean creases within kTipReachRimRadii of its centroid.
class RunCorners {
 public:
  struct Run {
    std::vector<std::size_t> crossings;  //!< indices into the plan's crossings, in loop order
    std::optional<Vec3> corner;          //!< none where the creases do not meet near the hole
    double farthest = 0;                 //!< farthest_bent_crease from the corner
  };

  //! \p centre, \p rim_radius: the rim's centroid and the largest distance of a rim vertex from
  //! it.
  RunCorners(const HoleCreasePlan& plan, std::span<const std::size_t> crossings,
             double line_tolerance, const Vec3& centre, double rim_radius)
      : plan_(plan),
        crossings_(crossings),
        line_tolerance_(line_tolerance),
        centre_(centre),
        rim_radius_(rim_radius),
        runs_(crossings.size() * crossings.size()) {}

  //! Whether \p p lies in the rim's ball (a hole around a box corner folds in every
  //! projection, and the box's corner can fall outside it: couplingdown_sharp #2's top corner).
  bool near_hole(const Vec3& p) const { return (p - centre_).norm() <= rim_radius_; }

  //! Whether the creases of \p run are clean: the other edges at each crossing bend by at most
  //! kFittedBendOtherRatio of its angle (a CAD part's, not a scan's rough "creases").
  bool clean(std::span<const std::size_t> run) const {
    return std::all_of(run.begin(), run.end(), [&](std::size_t i) {
      const CreaseCrossing& c = plan_.crossings[i];
      return c.other_bends_deg <= kFittedBendOtherRatio * c.dihedral_deg;
    });
  }

  //! Whether the bends of \p run are fitted along clean creases, each traced over
  //! kFittedBendEdges or more (a scan's rough "creases", traced over an edge or two among other
  //! bends, have no bend to go by: a bunny slot came out farther).
  bool bends_are_fitted(std::span<const std::size_t> run) const {
    return clean(run) && std::all_of(run.begin(), run.end(), [&](std::size_t i) {
             return plan_.crossings[i].traced_edges >= kFittedBendEdges;
           });
  }

  //! The run of \p length (1 to the count) crossings from position \p start, modulo the count.
  const Run& at(std::size_t start, std::size_t length) {
    const std::size_t count = crossings_.size();
    start %= count;
    std::optional<Run>& slot = runs_[start * count + length - 1];
    if (slot) return *slot;
    Run run;
    for (std::size_t k = 0; k < length; ++k)
      run.crossings.push_back(crossings_[(start + k) % count]);
    if (const std::optional<Vec3> lines = corner_ahead_of(plan_, run.crossings, line_tolerance_)) {
      const std::optional<Vec3> corner = corner_of_bent_creases(plan_, run.crossings, *lines);
      if (corner && near_enough(run.crossings, *corner)) {
        run.corner = corner;
        run.farthest = farthest_bent_crease(plan_, run.crossings, *corner);
      }
    } else if (const std::optional<Vec3> near_lines =
                   nearest_to_tangent_lines(plan_, run.crossings)) {
      // A crease that curves into its corner misses it along its tangent line by more than the
      // tolerance (fandisk's curved top ridge, meeting a straight one: 0.25 off its tangent, a
      // fifth of the hole's diameter): its bent crease must pass within it instead, and the
      // corner lie ahead of every crossing. A clean crease traced over fewer than
      // kFittedBendEdges has no bend to go by and goes straight on along its tangent, if another
      // crease of the run has its bend fitted (a short straight edge into the corner that a
      // curved one reaches: fandisk crease slot s8c9 hole 752).
      const auto fitted = [&](std::size_t i) {
        return plan_.crossings[i].traced_edges >= kFittedBendEdges;
      };
      const auto project = [&](std::size_t i, const Vec3& x) {
        const CreaseCrossing& c = plan_.crossings[i];
        return fitted(i) ? project_on_bent_crease(c, x) : project_on_ray(c.position, c.inward, x);
      };
      std::optional<Vec3> corner;
      if (clean(run.crossings) && std::any_of(run.crossings.begin(), run.crossings.end(), fitted))
        corner = meeting_point(
            *near_lines, (*near_lines - plan_.crossings[run.crossings.front()].position).norm(),
            [&](const Vec3& x, std::vector<CurveProjection>& out) {
              out.clear();
              for (const std::size_t i : run.crossings) out.push_back(project(i, x));
            });
      if (corner && near_enough(run.crossings, *corner) &&
          ahead_of_every_crossing(run.crossings, *corner)) {
        double farthest = 0;
        for (const std::size_t i : run.crossings)
          farthest = std::max(farthest, (project(i, *corner).point - *corner).norm());
        if (farthest <= line_tolerance_) {
          run.corner = corner;
          run.farthest = farthest;
        }
      }
    }
    return slot.emplace(std::move(run));
  }

  //! Whether a corner of the creases of \p run may lie at \p corner: in the rim's ball, or for
  //! creases with fitted bends within kTipReachRimRadii of its centre.
  bool near_enough(std::span<const std::size_t> run, const Vec3& corner) const {
    return near_hole(corner) ||
           ((corner - centre_).norm() <= kTipReachRimRadii * rim_radius_ && bends_are_fitted(run));
  }

 private:
  bool ahead_of_every_crossing(std::span<const std::size_t> run, const Vec3& corner) const {
    for (const std::size_t i : run)
      if (!(OpenMesh::dot(corner - plan_.crossings[i].position, plan_.crossings[i].inward) > 0))
        return false;
    return true;
  }

  const HoleCreasePlan& plan_;
  std::span<const std::size_t> crossings_;
  double line_tolerance_;
  Vec3 centre_;
  double rim_radius_;
  std::vector<std::optional<Run>> runs_;  // by start · count + length - 1
};

//! Appends \p corner to the plan and a curve to it from each of \p crossings.
//! Makes \p curve run from crossing \p c along its tangent to \p end, arriving as a circular arc
//! would (the start tangent mirrored about the chord). False where \p end is at the crossing
//! (no curve needed).
bool arrive_at(CreaseCurve& curve, const CreaseCrossing& c, const Vec3& end,
               const HermiteOptions& hermite, double tolerance) {
  const Vec3 chord = end - c.position;
  const Vec3 unit = Vec3(chord).normalize_cond();
  const Vec3 end_direction = 2.0 * OpenMesh::dot(c.inward, unit) * unit - c.inward;
  curve.points = {c.far_point, c.position, end, end + chord.norm() * end_direction};
  const HermiteCurveResult r = make_hermite_curve(curve.points, hermite, tolerance);
  if (!r.curve) return false;
  curve.curve = *r.curve;
  return true;
}

void add_corner(HoleCreasePlan& plan, std::span<const std::size_t> crossings, const Vec3& corner,
                const HermiteOptions& hermite, double tolerance) {
  for (const std::size_t i : crossings) {
    CreaseCurve curve;
    curve.from = i;
    curve.corner = plan.corners.size();
    if (arrive_at(curve, plan.crossings[i], corner, hermite, tolerance))
      plan.curves.push_back(curve);
  }
  plan.corners.push_back(corner);
}

//! Appends corners in a row, each with the curves from its run's crossings (add_corner), each
//! joined to the next by a straight crease (corner_links): the two-, three- and four-corner
//! plans.
void add_corners_in_a_row(HoleCreasePlan& plan,
                          std::initializer_list<std::pair<const RunCorners::Run*, Vec3>> row,
                          const HermiteOptions& hermite, double tolerance) {
  const std::size_t first = plan.corners.size();
  for (const auto& [run, corner] : row)
    add_corner(plan, run->crossings, corner, hermite, tolerance);
  for (std::size_t k = first + 1; k < plan.corners.size(); ++k)
    plan.corner_links.emplace_back(k - 1, k);
}

//! Moves corner \p k of \p plan onto the rim vertex of crossing \p at (the creases meet at a
//! corner of the part that the cut left on the rim): the curves from the corner's other creases
//! end at that crossing, arriving as they arrived at the corner; the crossing's own curve goes;
//! a link from the corner to another becomes a straight crease from the crossing to that one.
//! The corner leaves plan.corners (the later ones move down by one).
void move_corner_to_rim(HoleCreasePlan& plan, std::size_t k, std::size_t at,
                        const HermiteOptions& hermite, double tolerance) {
  const Vec3 end = plan.crossings[at].position;
  std::vector<CreaseCurve> curves;
  for (CreaseCurve& curve : plan.curves) {
    if (curve.to || curve.corner != k) {
      curves.push_back(std::move(curve));
      continue;
    }
    if (curve.from == at) continue;
    curve.to = at;
    if (arrive_at(curve, plan.crossings[curve.from], end, hermite, tolerance))
      curves.push_back(std::move(curve));
  }
  std::vector<std::pair<std::size_t, std::size_t>> links;
  for (const auto& [a, b] : plan.corner_links) {
    if (a != k && b != k) {
      links.emplace_back(a, b);
      continue;
    }
    // The link, a straight crease between the corners, now leaves the rim at the crossing.
    const std::size_t other = a == k ? b : a;
    const Vec3 chord = plan.corners[other] - end;
    CreaseCurve curve;
    curve.from = at;
    curve.corner = other;
    curve.points = {end - chord, end, plan.corners[other], plan.corners[other] + chord};
    const HermiteCurveResult r = make_hermite_curve(curve.points, hermite, tolerance);
    if (!r.curve) continue;
    curve.curve = *r.curve;
    curves.push_back(std::move(curve));
  }
  for (CreaseCurve& curve : curves)
    if (!curve.to && curve.corner > k) --curve.corner;
  for (auto& [a, b] : links) {
    if (a > k) --a;
    if (b > k) --b;
  }
  plan.curves = std::move(curves);
  plan.corner_links = std::move(links);
  plan.corners.erase(plan.corners.begin() + static_cast<std::ptrdiff_t>(k));
}

}  // namespace

bool join_at_corner(HoleCreasePlan& plan, std::span<const std::size_t> crossings,
                    double line_tolerance, const HermiteOptions& hermite, double tolerance) {
  if (crossings.size() < 3) return false;
  const std::optional<Vec3> corner = corner_ahead_of(plan, crossings, line_tolerance);
  if (!corner) return false;
  add_corner(plan, crossings, *corner, hermite, tolerance);
  return true;
}

namespace {

//! Four or more creases left over may meet at two corners joined by a straight crease
//! (couplingdown_sharp #2: a box edge's two top creases meet at one corner, from which a
//! vertical edge drops to where a chamfer's creases and a third edge meet). The crossings (in
//! loop order) are split into two runs of at least two, contiguous along the loop so that the
//! curves cannot cross; each run's corner is the one \p runs works out (RunCorners: its tangent
//! lines' meeting point, moved to where its bent creases come closest, near the hole).
//! Of the splits that qualify, the one whose creases pass closest to their corners (the larger
//! of the two corners' farthest_bent_crease) is taken; \p farthest receives that distance.
bool join_at_two_corners(HoleCreasePlan& plan, std::span<const std::size_t> crossings,
                         RunCorners& runs, const HermiteOptions& hermite, double tolerance,
                         double& farthest) {
  const std::size_t count = crossings.size();
  if (count < 4) return false;
  double best_score = std::numeric_limits<double>::infinity();
  const RunCorners::Run* best_a = nullptr;
  const RunCorners::Run* best_b = nullptr;
  // Each split once: `a` is the run that holds the first crossing.
  for (std::size_t length = 2; length + 2 <= count; ++length)
    for (std::size_t offset = 0; offset < length; ++offset) {
      const std::size_t start = (count - offset) % count;
      const RunCorners::Run& a = runs.at(start, length);
      const RunCorners::Run& b = runs.at(start + length, count - length);
      if (!a.corner || !b.corner) continue;
      const double score = std::max(a.farthest, b.farthest);
      if (score < best_score) {
        best_score = score;
        best_a = &a;
        best_b = &b;
      }
    }
  if (!best_a) return false;
  farthest = best_score;
  add_corners_in_a_row(plan, {{best_a, *best_a->corner}, {best_b, *best_b->corner}}, hermite,
                       tolerance);
  return true;
}

//! The unit normal of the face beside the rim edge from loop vertex \p i to its neighbour
//! ahead (\p ahead) or behind, or zero where there is none.
Vec3 rim_face_normal(const Mesh& mesh, const Hole& hole, std::size_t i, bool ahead) {
  const std::size_t n = hole.loop.size();
  const HalfedgeHandle h =
      mesh.find_halfedge(hole.loop[i], hole.loop[ahead ? (i + 1) % n : (i + n - 1) % n]);
  if (!h.is_valid()) return Vec3(0, 0, 0);
  FaceHandle f = mesh.face_handle(h);
  if (!f.is_valid()) f = mesh.face_handle(mesh.opposite_halfedge_handle(h));
  if (!f.is_valid()) return Vec3(0, 0, 0);
  return mesh.calc_face_normal(f).normalize_cond();
}

//! The direction in which a crease leaves the corner of \p run (creases contiguous along the
//! loop) towards \p towards: the edge of the two faces on the outer sides of the run's first and
//! last creases, which meet at the corner along with the faces between them (a polyhedron's
//! vertex of three faces has three edges, each the meeting of two of the faces). None when the
//! two faces are nearly parallel. The outer faces are the end creases' own (CreaseCrossing::
//! faces): the rim triangle just outside a crease's rim vertex may still belong to the face
//! between (fandisk ball cut s4c0 hole 1358: the link came out across the part, 17.3 -> 1.25 per
//! mille); the rim faces are the fallback where a crossing has no faces.
std::optional<Vec3> edge_of_outer_faces(const Mesh& mesh, const Hole& hole,
                                        const HoleCreasePlan& plan,
                                        std::span<const std::size_t> run, const Vec3& corner,
                                        const Vec3& towards) {
  // The outer face of an end crease is the one of its two faces that its neighbour in the run
  // does not share (the pair of faces, one from each, that lie closest is the shared one).
  const auto outer_face = [&](std::size_t end, std::size_t neighbour) -> std::optional<Vec3> {
    const CreaseCrossing& a = plan.crossings[end];
    const CreaseCrossing& b = plan.crossings[neighbour];
    if (!(a.faces[0].sqrnorm() > 0 && a.faces[1].sqrnorm() > 0 && b.faces[0].sqrnorm() > 0 &&
          b.faces[1].sqrnorm() > 0))
      return std::nullopt;
    double closest = -2;
    std::size_t shared = 0;
    for (std::size_t i = 0; i < 2; ++i)
      for (std::size_t j = 0; j < 2; ++j)
        if (const double c = OpenMesh::dot(a.faces[i], b.faces[j]); c > closest) {
          closest = c;
          shared = i;
        }
    return a.faces[1 - shared];
  };
  std::optional<Vec3> behind, ahead;
  if (run.size() >= 2) {
    behind = outer_face(run.front(), run[1]);
    ahead = outer_face(run.back(), run[run.size() - 2]);
  }
  if (!behind || !ahead) {
    behind = rim_face_normal(mesh, hole, plan.crossings[run.front()].loop_index, false);
    ahead = rim_face_normal(mesh, hole, plan.crossings[run.back()].loop_index, true);
  }
  Vec3 edge = OpenMesh::cross(*behind, *ahead);
  constexpr double kMinSine = 0.17;  // the faces differ by at least 10°
  if (!(edge.norm() >= kMinSine)) return std::nullopt;
  edge.normalize();
  return OpenMesh::dot(edge, towards - corner) < 0 ? -edge : edge;
}

//! Where the links (rays from corners: origin, direction) and the bent creases of \p
//! crossings come closest: meeting_point from the point nearest all their lines, scaled by its
//! distance from the first link's corner. None where their lines fix no point. A middle corner
//! of three or four in a row, which its creases alone cannot place.
std::optional<Vec3> meeting_of_links_and_creases(const HoleCreasePlan& plan,
                                                 std::span<const std::pair<Vec3, Vec3>> links,
                                                 std::span<const std::size_t> crossings) {
  std::vector<Vec3> origins, directions;
  for (const auto& [origin, direction] : links) {
    origins.push_back(origin);
    directions.push_back(direction);
  }
  for (const std::size_t i : crossings) {
    origins.push_back(plan.crossings[i].position);
    directions.push_back(plan.crossings[i].inward);
  }
  const std::optional<Vec3> start = nearest_point_to_lines(origins, directions);
  if (!start) return std::nullopt;
  return meeting_point(*start, (*start - links.front().first).norm(),
                       [&](const Vec3& x, std::vector<CurveProjection>& out) {
                         out.clear();
                         for (const auto& [origin, direction] : links)
                           out.push_back(project_on_ray(origin, direction, x));
                         for (const std::size_t k : crossings)
                           out.push_back(project_on_bent_crease(plan.crossings[k], x));
                       });
}

//! Five or more creases left over may meet at three corners in a row, A - B - C
//! (couplingdown_sharp #2: two top creases meet at A, from which a vertical edge drops to B,
//! where one chamfer crease ends, and a short edge leads on to C, where the other chamfer
//! crease and a step's crease meet). The crossings (in loop order) are split into three runs
//! contiguous along the loop; the ends A and C take at least two creases each, placed as in
//! join_at_two_corners. Each end's link leaves along the edge of its run's outer faces
//! (edge_of_outer_faces): B, whose creases alone cannot place it, is where its bent creases and
//! the two links come closest. Of the splits whose creases and links pass within \p within of
//! their corners, the one where they pass closest is taken; \p farthest receives that distance.
bool join_at_three_corners(HoleCreasePlan& plan, const Mesh& mesh, const Hole& hole,
                           std::span<const std::size_t> crossings, RunCorners& runs,
                           const HermiteOptions& hermite, double tolerance, double within,
                           double& farthest) {
  const std::size_t count = crossings.size();
  if (count < 5) return false;
  struct Split {
    const RunCorners::Run* a;
    const RunCorners::Run* b;
    const RunCorners::Run* c;
    Vec3 corner_b;
  };
  std::optional<Split> best;
  // A split replaces the best so far when it passes strictly closer; the first must pass within
  // `within` (inclusive).
  double best_score = std::nextafter(within, std::numeric_limits<double>::infinity());
  // Each split and choice of middle once: a is the run just before the middle b.
  for (std::size_t start = 0; start < count; ++start)
    for (std::size_t length_a = 2; length_a + 3 <= count; ++length_a)
      for (std::size_t length_b = 1; length_a + length_b + 2 <= count; ++length_b) {
        const RunCorners::Run& a = runs.at(start, length_a);
        const RunCorners::Run& b = runs.at(start + length_a, length_b);
        const RunCorners::Run& c =
            runs.at(start + length_a + length_b, count - length_a - length_b);
        // Ends that already pass no closer than the best cannot make a better split.
        if (!a.corner || !c.corner || !(std::max(a.farthest, c.farthest) < best_score)) continue;
        // Where b's creases head (their crossings' centroid): the links leave towards it.
        Vec3 towards(0, 0, 0);
        for (const std::size_t i : b.crossings) towards += plan.crossings[i].position;
        towards /= static_cast<double>(b.crossings.size());
        const auto link_a = edge_of_outer_faces(mesh, hole, plan, a.crossings, *a.corner, towards);
        const auto link_c = edge_of_outer_faces(mesh, hole, plan, c.crossings, *c.corner, towards);
        if (!link_a || !link_c) continue;
        // B: where the bent creases of its run and the two links come closest.
        const std::array<std::pair<Vec3, Vec3>, 2> links{
            {{*a.corner, *link_a}, {*c.corner, *link_c}}};
        const std::optional<Vec3> meeting_b =
            meeting_of_links_and_creases(plan, links, b.crossings);
        if (!meeting_b) continue;
        const auto on_link = [&](std::size_t k, const Vec3& x) {
          return project_on_ray(links[k].first, links[k].second, x);
        };
        const Vec3& corner_b = *meeting_b;
        if (!runs.near_hole(corner_b) || !(OpenMesh::dot(corner_b - *a.corner, *link_a) > 0) ||
            !(OpenMesh::dot(corner_b - *c.corner, *link_c) > 0))
          continue;
        const double score =
            std::max({a.farthest, c.farthest, farthest_bent_crease(plan, b.crossings, corner_b),
                      (on_link(0, corner_b).point - corner_b).norm(),
                      (on_link(1, corner_b).point - corner_b).norm()});
        if (score < best_score) {
          best_score = score;
          best = Split{&a, &b, &c, corner_b};
        }
      }
  if (!best) return false;
  farthest = best_score;
  add_corners_in_a_row(
      plan, {{best->a, *best->a->corner}, {best->b, best->corner_b}, {best->c, *best->c->corner}},
      hermite, tolerance);
  return true;
}

//! A corner's link may not leave within this angle of one of its creases' lines: at a corner of
//! faces, each edge is the meeting of another pair of them.
constexpr double kLinkOffCreaseDeg = 20.0;

//! The directions in which a link may leave the corner of \p run towards \p towards: the edge of
//! its outer faces (edge_of_outer_faces) and the edges of the other pairs of its end creases'
//! faces, each leaving at least kLinkOffCreaseDeg off the line along which every crease of the
//! run arrives at the corner (arrive_at's end direction). At a corner of four faces the outer
//! faces are ambiguous: a fandisk ball cut through the end of its step (ball-cut bench seed 4
//! cut 4, hole 1073) has a ridge's faces as close to one as to the other face of the side plane's
//! edge, and the outer faces' edge ran back along the ridge.
std::vector<Vec3> corner_edges(const Mesh& mesh, const Hole& hole, const HoleCreasePlan& plan,
                               std::span<const std::size_t> run, const Vec3& corner,
                               const Vec3& towards) {
  std::vector<Vec3> candidates;
  if (const auto edge = edge_of_outer_faces(mesh, hole, plan, run, corner, towards))
    candidates.push_back(*edge);
  const CreaseCrossing& front = plan.crossings[run.front()];
  const CreaseCrossing& back = plan.crossings[run.back()];
  constexpr double kMinSine = 0.17;  // as edge_of_outer_faces: faces at least 10° apart
  for (const Vec3& a : front.faces)
    for (const Vec3& b : back.faces) {
      Vec3 edge = OpenMesh::cross(a, b);
      if (!(edge.norm() >= kMinSine)) continue;
      edge.normalize();
      candidates.push_back(OpenMesh::dot(edge, towards - corner) < 0 ? -edge : edge);
    }
  const double off_crease_cos = std::cos(kLinkOffCreaseDeg * std::numbers::pi / 180.0);
  const double same_cos = std::cos(std::numbers::pi / 180.0);  // edges within 1° are one
  std::vector<Vec3> out;
  for (const Vec3& edge : candidates) {
    bool off_every_crease = true;
    for (const std::size_t i : run) {
      const CreaseCrossing& c = plan.crossings[i];
      const Vec3 unit = Vec3(corner - c.position).normalize_cond();
      const Vec3 arrival = 2.0 * OpenMesh::dot(c.inward, unit) * unit - c.inward;
      off_every_crease = off_every_crease && std::abs(OpenMesh::dot(edge, arrival)) <
                                                 off_crease_cos * std::max(arrival.norm(), 1e-300);
    }
    const bool known = std::any_of(out.begin(), out.end(), [&](const Vec3& e) {
      return std::abs(OpenMesh::dot(e, edge)) > same_cos;
    });
    if (off_every_crease && !known) out.push_back(edge);
  }
  return out;
}

//! Six or more creases left over may meet at four corners in a row, A - B - C - D (a fandisk
//! ball cut through the end of its step, where the step's two creases and the ridges of the
//! faces beside it meet the side face: the side face's edges link the corners). The crossings
//! (in loop order) are split into four runs contiguous along the loop; the ends A and D take at
//! least two creases each, placed as in join_at_two_corners, the middles B and C one or more.
//! Each end's link leaves along an edge of its end creases' faces (corner_edges), either way,
//! and its neighbour in the middle is where that link and the neighbour's bent creases come
//! closest (the edge and way where they come closest of all); B and C are joined by a straight
//! crease. Of the splits whose creases and links pass within \p within of their corners, the
//! one where they pass closest is taken; \p farthest receives that distance.
bool join_at_four_corners(HoleCreasePlan& plan, const Mesh& mesh, const Hole& hole,
                          std::span<const std::size_t> crossings, RunCorners& runs,
                          const HermiteOptions& hermite, double tolerance, double within,
                          double& farthest) {
  const std::size_t count = crossings.size();
  if (count < 6) return false;
  struct Split {
    const RunCorners::Run* a;
    const RunCorners::Run* b;
    const RunCorners::Run* c;
    const RunCorners::Run* d;
    Vec3 corner_b, corner_c;
  };
  std::optional<Split> best;
  double best_score = std::nextafter(within, std::numeric_limits<double>::infinity());
  // Each (end, middle) pair once: the splits share them.
  std::map<std::pair<const RunCorners::Run*, const RunCorners::Run*>,
           std::optional<std::pair<Vec3, double>>>
      middles;
  // The middle corner next to end \p end (a run with a corner) along its link, towards the
  // crossings of \p middle: where the link and the middle's bent creases come closest, with how
  // far the farthest of them passes; none where it does not lie ahead along the link, near the
  // hole.
  const auto work_out_middle =
      [&](const RunCorners::Run& end,
          const RunCorners::Run& middle) -> std::optional<std::pair<Vec3, double>> {
    Vec3 towards(0, 0, 0);
    for (const std::size_t i : middle.crossings) towards += plan.crossings[i].position;
    towards /= static_cast<double>(middle.crossings.size());
    const std::vector<Vec3> edges =
        corner_edges(mesh, hole, plan, end.crossings, *end.corner, towards);
    std::optional<std::pair<Vec3, double>> found;
    for (const Vec3& edge : edges)
      for (const Vec3& link : {edge, -edge}) {
        // The edge's way is the one along which the middle's creases reach it (the middle's
        // crossings may lie off to the side of the link: the step's creases cross the hole
        // towards the side face that holds the links).
        const std::pair<Vec3, Vec3> from_end{*end.corner, link};
        const std::optional<Vec3> meeting =
            meeting_of_links_and_creases(plan, {&from_end, 1}, middle.crossings);
        if (!meeting || !runs.near_enough(middle.crossings, *meeting) ||
            !(OpenMesh::dot(*meeting - *end.corner, link) > 0))
          continue;
        const double off =
            std::max(farthest_bent_crease(plan, middle.crossings, *meeting),
                     (project_on_ray(*end.corner, link, *meeting).point - *meeting).norm());
        if (!found || off < found->second) found = std::pair{*meeting, off};
      }
    return found;
  };
  const auto middle_corner =
      [&](const RunCorners::Run& end,
          const RunCorners::Run& middle) -> const std::optional<std::pair<Vec3, double>>& {
    const auto key = std::pair{&end, &middle};
    auto it = middles.find(key);
    if (it == middles.end()) it = middles.emplace(key, work_out_middle(end, middle)).first;
    return it->second;
  };
  for (std::size_t start = 0; start < count; ++start)
    for (std::size_t length_a = 2; length_a + 4 <= count; ++length_a)
      for (std::size_t length_b = 1; length_a + length_b + 3 <= count; ++length_b)
        for (std::size_t length_c = 1; length_a + length_b + length_c + 2 <= count; ++length_c) {
          const RunCorners::Run& a = runs.at(start, length_a);
          const RunCorners::Run& b = runs.at(start + length_a, length_b);
          const RunCorners::Run& c = runs.at(start + length_a + length_b, length_c);
          const RunCorners::Run& d = runs.at(start + length_a + length_b + length_c,
                                             count - length_a - length_b - length_c);
          // A split whose ends, or first middle, already pass no closer than the best found
          // cannot replace it: the middles are not worked out (many splits share their runs,
          // and each middle takes a meeting-point search per edge and way).
          if (!a.corner || !d.corner || !(std::max(a.farthest, d.farthest) < best_score)) continue;
          const auto& corner_b = middle_corner(a, b);
          if (!corner_b || !(corner_b->second < best_score)) continue;
          const auto& corner_c = middle_corner(d, c);
          if (!corner_c) continue;
          const double score =
              std::max({a.farthest, d.farthest, corner_b->second, corner_c->second});
          if (score < best_score) {
            best_score = score;
            best = Split{&a, &b, &c, &d, corner_b->first, corner_c->first};
          }
        }
  if (!best) return false;
  farthest = best_score;
  add_corners_in_a_row(plan,
                       {{best->a, *best->a->corner},
                        {best->b, best->corner_b},
                        {best->c, best->corner_c},
                        {best->d, *best->d->corner}},
                       hermite, tolerance);
  return true;
}

//! Hermite control points (P1..P4) whose curve is the straight segment \p a -> \p b: a crease
//! known to be straight there, which fitted tangents would only bow off it.
HermitePoints straight_curve_points(const Vec3& a, const Vec3& b) {
  const Vec3 chord = b - a;
  return {a - chord, a, b, b + chord};
}

//! A crossing at rim vertex \p vertex (loop index \p loop_index, at \p position) where a crease
//! arriving from \p arriving ends: it continues that crease straight, its tangent \p inward
//! pointing back into the hole and its far point \p far_length beyond the vertex, for the
//! consumers that read a curve's end from its crossing.
CreaseCrossing crossing_ending_at(const CreaseCrossing& arriving, std::size_t loop_index,
                                  VertexHandle vertex, const Vec3& position, const Vec3& inward,
                                  double far_length) {
  CreaseCrossing c = arriving;
  c.loop_index = loop_index;
  c.vertex = vertex;
  c.position = position;
  c.inward = inward;
  c.bend_inward = inward;
  c.curvature = Vec3(0, 0, 0);
  c.near_rim = {position};
  c.far_point = position - far_length * inward;
  c.on_crease = position;
  c.traced_edges = 0;
  c.rim_run = 0;
  return c;
}

//! Whether a chord between loop indices \p la and \p lb separates the two ends of a pair of
//! \p plan (a curve between two crossings).
bool separates_a_pair(const HoleCreasePlan& plan, std::size_t la, std::size_t lb) {
  for (const CreaseCurve& c : plan.curves)
    if (c.to &&
        interleaved(la, lb, plan.crossings[c.from].loop_index, plan.crossings[*c.to].loop_index))
      return true;
  return false;
}

//! Creases left over that run straight into a rim vertex where a crease meets the rim end
//! there: the cut went through a corner of the part, so the creases meet on the rim and not
//! inside the hole (the least-squares corner of join_at_corners then falls on the rim, outside
//! the hole's projection, and is refused). A crossing of \p left gets a straight curve to the
//! first rim vertex ahead on its tangent line (within \p line_tolerance of the line and
//! \p max_turn radians of the tangent, seen from the crossing) if a crease meets the rim there,
//! or the rim goes on from there along that line (each rim edge within \p max_turn of it) to a
//! vertex where one does, and the curve crosses no curve of \p plan. Crossings at that vertex, and
//! at its rim neighbours heading along the rim edge to it (their crease is that edge), are matched
//! too. Returns the crossings of \p left still unmatched.
std::vector<std::size_t> end_at_rim_corners(HoleCreasePlan& plan, FaceNormals& normals,
                                            const Hole& hole, std::span<const std::size_t> left,
                                            const SharpAngle& sharp, double line_tolerance,
                                            double max_turn, double fit_length,
                                            const HermiteOptions& hermite, double tolerance) {
  const Mesh& mesh = normals.mesh();
  const std::size_t n = hole.loop.size();
  // A crease leaves loop vertex j outside the hole (is_sharp: never a rim edge). Not a crossing
  // whose crease ran along the rim to j: measured on random cuts of couplingdown, such vertices
  // were mostly where a chamfer's edge leaves the rim, and curves to them took fills farther
  // from the removed surface (one from 5.4 to 54 per mille Hausdorff).
  const auto on_crease = [&](std::size_t j) {
    for (const HalfedgeHandle o : mesh.voh_range(hole.loop[j]))
      if (is_sharp(normals, o, sharp)) return true;
    return false;
  };
  // Whether a curve of \p plan leaves loop vertex j within kMinCurveAngleDeg of the direction
  // towards \p to: the two would bound a sliver of a region (fandisk: a pair that took a
  // crease's crossing for a nearly parallel one's, 11.5° from the true crease).
  constexpr double kMinCurveAngleDeg = 30.0;
  const auto beside_a_curve = [&](std::size_t j, const Vec3& to) {
    const Vec3 at = mesh.point(hole.loop[j]);
    const Vec3 towards = Vec3(to - at).normalize_cond();
    for (const CreaseCurve& c : plan.curves) {
      if (!c.to) continue;
      const CreaseCrossing& from = plan.crossings[c.from];
      const CreaseCrossing& end = plan.crossings[*c.to];
      if (from.loop_index != j && end.loop_index != j) continue;
      const Vec3 other = from.loop_index == j ? end.position : from.position;
      if (angle_between(towards, other - at) < kMinCurveAngleDeg * kDeg) return true;
    }
    return false;
  };
  const auto crossing_at = [&](std::size_t j) -> std::optional<std::size_t> {
    for (std::size_t x = 0; x < plan.crossings.size(); ++x)
      if (plan.crossings[x].loop_index == j) return x;
    return std::nullopt;
  };
  // Whether rim vertex j lies ahead of crossing c on its tangent line (within line_tolerance and
  // max_turn seen from c), how far along the line.
  const auto ahead_on_line = [&](const CreaseCrossing& c, std::size_t j) -> std::optional<double> {
    const Vec3 d = mesh.point(hole.loop[j]) - c.position;
    const double along = OpenMesh::dot(d, c.inward);
    const double off = (d - along * c.inward).norm();
    if (!(along > 0) || off > line_tolerance || std::atan2(off, along) > max_turn)
      return std::nullopt;
    return along;
  };
  // Whether the rim goes on from loop vertex j along the tangent line of c (each rim edge
  // within max_turn of the direction from c to j, each vertex ahead on the line) to a vertex
  // where a crease meets the rim.
  const auto runs_along_rim_to_crease = [&](const CreaseCrossing& c, std::size_t j) {
    if (!ahead_on_line(c, j)) return false;
    const Vec3 direction = Vec3(mesh.point(hole.loop[j]) - c.position).normalize_cond();
    for (const std::size_t step : {std::size_t{1}, n - 1}) {
      std::size_t previous = j;
      for (std::size_t k = (j + step) % n, walked = 0; k != c.loop_index && walked + 2 < n;
           previous = k, k = (k + step) % n, ++walked) {
        const Vec3 edge = mesh.point(hole.loop[k]) - mesh.point(hole.loop[previous]);
        if (!ahead_on_line(c, k) || !(angle_between(edge, direction) <= max_turn)) break;
        if (on_crease(k)) return true;
      }
    }
    return false;
  };
  std::vector<bool> matched(plan.crossings.size(), false);
  for (const std::size_t a : left) {
    if (matched[a]) continue;
    const CreaseCrossing& ca = plan.crossings[a];
    std::optional<std::size_t> best;
    double best_along = std::numeric_limits<double>::infinity();
    for (std::size_t j = 0; j < n; ++j) {
      if (j == ca.loop_index || j == (ca.loop_index + 1) % n || (j + 1) % n == ca.loop_index)
        continue;
      const std::optional<double> along = ahead_on_line(ca, j);
      if (!along || *along >= best_along) continue;
      best = j;
      best_along = *along;
    }
    // The first rim vertex the line meets must be the corner: a crease that passes a vertex
    // where no crease meets the rim crosses the hole there (or runs along the rim), and ends
    // at no corner. Unless the rim goes on along the line from there to a vertex where a crease
    // meets it: the crease reaches the rim at the first vertex and runs along rim edges to its
    // corner (fandisk's top edge up to the tongue's root, ball cut s11c7 hole 1562: 3.9 ->
    // 20.6°, 0.40 -> 0.42‰ mean; the only other fill of the cut benches that changed moved by
    // 0.003‰). Without the rim edges held to the line, a curved ridge's tangent took a vertex
    // where the rim turns away (s2c1 hole 1137 2.55 -> 3.40‰).
    if (!best || !(on_crease(*best) || runs_along_rim_to_crease(ca, *best)) ||
        separates_a_pair(plan, ca.loop_index, *best) || beside_a_curve(*best, ca.position))
      continue;
    const std::size_t j = *best;
    const Vec3 corner = mesh.point(hole.loop[j]);
    const Vec3 chord = corner - ca.position;
    const Vec3 unit = Vec3(chord).normalize_cond();
    // Straight from the crossing to the vertex: both lie on the crease, which a part's corner
    // ends (the fitted tangent, within the few degrees allowed, would bow the curve off it).
    CreaseCurve curve;
    curve.from = a;
    curve.points = straight_curve_points(ca.position, corner);
    const HermiteCurveResult r = make_hermite_curve(curve.points, hermite, tolerance);
    if (!r.curve) continue;
    curve.curve = *r.curve;
    std::optional<std::size_t> end = crossing_at(j);
    if (!end) {
      // The crease ends at the vertex: a crossing there continuing it straight (as the curve
      // arrives), for the consumers that read a curve's end from its crossing.
      plan.crossings.push_back(crossing_ending_at(ca, j, hole.loop[j], corner, -unit, fit_length));
      matched.push_back(false);
      end = plan.crossings.size() - 1;
    }
    curve.to = end;
    plan.curves.push_back(curve);
    matched[a] = true;
    matched[*end] = true;
    // A crossing next to the corner whose crease heads along the rim edge to it: that edge is
    // the crease.
    for (const std::size_t k : {(j + 1) % n, (j + n - 1) % n})
      if (const auto x = crossing_at(k)) {
        const Vec3 to_corner = Vec3(corner - plan.crossings[*x].position).normalize_cond();
        if (OpenMesh::dot(to_corner, plan.crossings[*x].inward) > std::cos(max_turn))
          matched[*x] = true;
      }
  }
  std::vector<std::size_t> out;
  for (const std::size_t a : left)
    if (!matched[a]) out.push_back(a);
  return out;
}

//! The median dihedral angle near a hole (median_dihedral_near), worked out once, when first
//! asked (or known from the shape decision): a CAD part's surroundings have it under a degree.
class MedianDihedral {
 public:
  MedianDihedral(FaceNormals& normals, const Hole& hole, std::optional<double> known)
      : normals_(normals), hole_(hole), value_(known) {}
  double operator()() {
    if (!value_) value_ = median_dihedral_near(normals_.mesh(), hole_, normals_);
    return *value_;
  }

 private:
  FaceNormals& normals_;
  const Hole& hole_;
  std::optional<double> value_;
};

//! Whether the creases of crossings \p a and \p b both bound one planar face: a face normal of
//! each within kSharedFaceDeg of the other, each crossing on the other's face plane and both
//! creases' tangents in it (all to within the same angle, seen along the chord).
bool bound_one_face(const CreaseCrossing& a, const CreaseCrossing& b) {
  constexpr double kSharedFaceDeg = 2.0;
  const double sine = std::sin(kSharedFaceDeg * kDeg);
  const Vec3 chord = b.position - a.position;
  const double length = chord.norm();
  if (!(length > 0)) return false;
  for (const Vec3& fa : a.faces)
    for (const Vec3& fb : b.faces)
      if (angle_between(fa, fb) <= kSharedFaceDeg * kDeg &&
          std::abs(OpenMesh::dot(fa, chord)) <= sine * length &&
          std::abs(OpenMesh::dot(fb, chord)) <= sine * length &&
          std::abs(OpenMesh::dot(fa, a.inward)) <= sine &&
          std::abs(OpenMesh::dot(fb, b.inward)) <= sine)
        return true;
  return false;
}

//! Crossings left over after the pairs and corners, joined two by two where both creases bound
//! one planar face of a CAD part: the face's edge is one crease however far it turns inside the
//! hole (fandisk's tongue, whose flat underside is bounded by a U: ball cut s5c4 hole 638 enters
//! 67° off the chord and leaves 48° off it, past `loose_pair_angle_deg`, and the 3D fill across
//! it came out 9.8‰ off with 3.6° slivers). The Hermite curve of such a pair lies in the face's
//! plane (its tangents do) and may turn up to a U (HermiteOptions' a(θ)). Taken only on a CAD
//! part's surroundings (kCadMedianDihedralDeg, as join_at_corners' two-crease corner: a
//! scan's faces are never exactly coplanar, and a looser tangent agreement measured farther on
//! its random cuts), when neither end's tangent turns more than kMaxTurnDeg off the chord (a
//! crease heading away from its partner is not its partner), the crossings lie at least
//! kMinChordEdges mean rim edges apart, the curve stays inside the hole's projection and crosses
//! no curve of \p plan; the least turning pairs first. Returns the crossings of \p left still
//! unmatched.
//!
//! Two edges of one face that cross the rim close together meet at a corner by the rim, which a
//! curve between them rounds off: measured on the cut benches (ball cuts seeds 1-12, crease
//! slots 1-20), the pairs 0.95-4.0 mean rim edges apart made four fills worse (crease slot s14c6
//! hole 1278 29.3 -> 14.9°, ball cut s7c3 hole 555 11.4 -> 14.3‰ mean), those 6.5-15.5 apart
//! made eleven closer to the removed faces on average (two with a larger Hausdorff distance)
//! and none farther.
std::vector<std::size_t> pair_along_shared_faces(
    HoleCreasePlan& plan, MedianDihedral& median_dihedral, const Hole& hole,
    std::span<const std::size_t> left, const CreaseOptions& options, double tolerance,
    const std::function<bool(const Vec3&)>& inside_hole) {
  constexpr double kMaxTurnDeg = 95.0;
  constexpr double kMinChordEdges = 5.0;
  struct SharedFacePair {
    double score;
    std::size_t a, b;
  };
  std::vector<SharedFacePair> candidates;
  for (std::size_t x = 0; x < left.size(); ++x)
    for (std::size_t y = x + 1; y < left.size(); ++y) {
      const CreaseCrossing& ca = plan.crossings[left[x]];
      const CreaseCrossing& cb = plan.crossings[left[y]];
      if (ca.loop_index == cb.loop_index || ca.convex != cb.convex ||
          std::max(ca.dihedral_deg, cb.dihedral_deg) >
              options.max_pair_dihedral_ratio * std::min(ca.dihedral_deg, cb.dihedral_deg) ||
          !bound_one_face(ca, cb))
        continue;
      const Vec3 chord = cb.position - ca.position;
      if (chord.norm() < kMinChordEdges * hole.mean_edge_length) continue;
      const double score =
          std::max(angle_between(ca.inward, chord), angle_between(cb.inward, -chord));
      if (score <= kMaxTurnDeg * kDeg) candidates.push_back({score, left[x], left[y]});
    }
  if (candidates.empty() || !(median_dihedral() < kCadMedianDihedralDeg))
    return {left.begin(), left.end()};
  std::sort(candidates.begin(), candidates.end(),
            [](const SharedFacePair& p, const SharedFacePair& q) { return p.score < q.score; });
  const std::size_t n = hole.loop.size();
  // Whether a pair between loop indices la and lb separates the crossings of a curve of the plan
  // (a pair's two ends, or all the creases to one corner).
  const auto crosses_a_curve = [&](std::size_t la, std::size_t lb) {
    const std::size_t span = (lb + n - la) % n;
    const auto inside = [&](std::size_t i) {
      const std::size_t offset = (plan.crossings[i].loop_index + n - la) % n;
      return offset > 0 && offset < span;
    };
    if (separates_a_pair(plan, la, lb)) return true;
    for (const CreaseCurve& c : plan.curves) {
      if (c.to) continue;
      for (const CreaseCurve& d : plan.curves)
        if (!d.to && d.corner == c.corner && inside(c.from) != inside(d.from)) return true;
    }
    return false;
  };
  std::set<std::size_t> used;
  for (const SharedFacePair& p : candidates) {
    if (used.count(p.a) || used.count(p.b)) continue;
    const CreaseCrossing& ca = plan.crossings[p.a];
    const CreaseCrossing& cb = plan.crossings[p.b];
    if (crosses_a_curve(ca.loop_index, cb.loop_index)) continue;
    CreaseCurve curve;
    curve.from = p.a;
    curve.to = p.b;
    curve.points = {ca.far_point, ca.position, cb.position, cb.far_point};
    const HermiteCurveResult r = make_hermite_curve(curve.points, options.hermite, tolerance);
    if (!r.curve) continue;
    const std::vector<CurveSample> samples = sample_by_arc_length(*r.curve, hole.mean_edge_length);
    if (!std::all_of(samples.begin() + 1, samples.end() - 1,
                     [&](const CurveSample& s) { return inside_hole(s.point); }))
      continue;
    curve.curve = *r.curve;
    curve.misfit = p.score;
    plan.curves.push_back(curve);
    used.insert(p.a);
    used.insert(p.b);
  }
  std::vector<std::size_t> out;
  for (const std::size_t a : left)
    if (!used.count(a)) out.push_back(a);
  return out;
}

//! Creases left over that run into a paired curve inside the hole end on it, at a corner there
//! (a T: where three faces of a CAD part meet and one of the edges goes on, as a valley meets the
//! U-shaped edge of fandisk's tongue by its root). A crossing of \p left ends on the first curve
//! of a pair (not an arc) that its tangent line meets ahead of it within \p line_tolerance, at
//! the curve's point nearest the line, if that point lies at least kMinEndEdges mean rim edges
//! from the crossing and from both ends of the curve and the crease's own curve to it (arriving
//! as a circular arc would, arrive_at) passes no other curve. The pair becomes the corner's two
//! other creases, the pieces of its curve on either side; the plan keeps the pair whole too
//! (pairs_split_at_corners), for the retry without corners. Taken only on a CAD part's
//! surroundings (kCadMedianDihedralDeg, as pair_along_shared_faces). Returns the crossings of
//! \p left still unmatched.
//!
//! Measured on the cut benches (ball cuts seeds 1-12, crease slots 1-20), all on fandisk: 11 fills
//! closer to the removed faces on average (ball cut s2c4 hole 6 1.60 -> 0.08‰, s12c4 hole 8 2.39 ->
//! 0.53‰, s9c1 hole 4 5.40 -> 3.33‰), 3 farther by at most 0.04‰; one fill's smallest angle
//! fell, s6c3 hole 403 11.6 -> 5.5° (its corner 0.77 mean rim edges from the pair's end).
std::vector<std::size_t> end_on_paired_curves(HoleCreasePlan& plan, MedianDihedral& median_dihedral,
                                              const Hole& hole, std::span<const std::size_t> left,
                                              double line_tolerance, const HermiteOptions& hermite,
                                              double tolerance) {
  constexpr double kMinEndEdges = 0.5;
  constexpr int kSamples = 64;
  const auto is_pair = [](const CreaseCurve& c) { return c.to && !c.arc; };
  if (left.empty() || std::none_of(plan.curves.begin(), plan.curves.end(), is_pair) ||
      !(median_dihedral() < kCadMedianDihedralDeg))
    return {left.begin(), left.end()};
  const double mean_edge = hole.mean_edge_length;
  const double near = kMinEndEdges * mean_edge;
  std::vector<std::size_t> out;
  for (const std::size_t u : left) {
    const CreaseCrossing& c = plan.crossings[u];
    // How far the curve's point at t lies from the crease's tangent line, and how far along it.
    const auto miss = [&](const HermiteCurve& curve, double t) {
      const Vec3 q = curve.at(t);
      const double along = OpenMesh::dot(q - c.position, c.inward);
      return std::pair{(q - (c.position + along * c.inward)).norm(), along};
    };
    struct Hit {
      std::size_t curve;
      double t, along;
    };
    std::optional<Hit> first;
    for (std::size_t i = 0; i < plan.curves.size(); ++i) {
      if (!is_pair(plan.curves[i])) continue;
      const HermiteCurve& curve = plan.curves[i].curve;
      int nearest = 0;
      double nearest_miss = std::numeric_limits<double>::infinity();
      for (int k = 1; k < kSamples; ++k) {
        const auto [d, along] = miss(curve, static_cast<double>(k) / kSamples);
        if (along > 0 && d < nearest_miss) {
          nearest_miss = d;
          nearest = k;
        }
      }
      if (nearest == 0) continue;
      // The nearest point between the neighbouring samples (the miss is unimodal there).
      double lo = static_cast<double>(nearest - 1) / kSamples;
      double hi = static_cast<double>(nearest + 1) / kSamples;
      for (int step = 0; step < 40; ++step) {
        const double m1 = lo + (hi - lo) / 3, m2 = hi - (hi - lo) / 3;
        if (miss(curve, m1).first < miss(curve, m2).first)
          hi = m2;
        else
          lo = m1;
      }
      const double t = 0.5 * (lo + hi);
      const auto [d, along] = miss(curve, t);
      if (!(d <= line_tolerance) || !(along >= near)) continue;
      const Vec3 at = curve.at(t);
      if ((at - curve.start).norm() < near || (at - curve.end).norm() < near) continue;
      if (!first || along < first->along) first = Hit{i, t, along};
    }
    if (!first) {
      out.push_back(u);
      continue;
    }
    const CreaseCurve pair = plan.curves[first->curve];
    const Vec3 corner = pair.curve.at(first->t);
    CreaseCurve arriving;
    arriving.from = u;
    arriving.corner = plan.corners.size();
    if (!arrive_at(arriving, c, corner, hermite, tolerance)) {
      out.push_back(u);
      continue;
    }
    // The crease's curve may pass no other curve on its way (only its end touches the pair's).
    const std::vector<CurveSample> path = sample_by_arc_length(arriving.curve, 0.5 * mean_edge);
    bool passes = false;
    std::vector<Vec3> other(kSamples + 1);
    for (std::size_t i = 0; i < plan.curves.size() && !passes; ++i) {
      for (int k = 0; k <= kSamples; ++k)
        other[static_cast<std::size_t>(k)] =
            point_on(plan.curves[i], static_cast<double>(k) / kSamples);
      for (std::size_t j = 0; j + 1 < path.size() && !passes; ++j) {
        if ((path[j + 1].point - corner).norm() < near) break;
        for (std::size_t k = 0; k + 1 < other.size() && !passes; ++k)
          passes = segment_segment_distance2(path[j].point, path[j + 1].point, other[k],
                                             other[k + 1]) < 0.0625 * mean_edge * mean_edge;
      }
    }
    if (passes) {
      out.push_back(u);
      continue;
    }
    const auto piece = [&](std::size_t from, double t0) {
      CreaseCurve curve;
      curve.from = from;
      curve.corner = arriving.corner;
      curve.curve = sub_curve(pair.curve, t0, first->t);
      curve.points = {curve.curve.start - curve.curve.start_tangent, curve.curve.start,
                      curve.curve.end, curve.curve.end + curve.curve.end_tangent};
      return curve;
    };
    plan.curves.erase(plan.curves.begin() + static_cast<std::ptrdiff_t>(first->curve));
    plan.curves.push_back(piece(pair.from, 0.0));
    plan.curves.push_back(piece(*pair.to, 1.0));
    plan.curves.push_back(arriving);
    plan.corners.push_back(corner);
    plan.pairs_split_at_corners.push_back(pair);
  }
  return out;
}

}  // namespace

//! join_at_corners: a corner this many mean rim edges from a crossing is on the rim. Measured on
//! the crease-slot bench, seeds 1-20: the corners that bounded needles (0.11-3.9°) of fandisk's
//! and couplingdown's splits lay 0.0005-0.14 mean rim edges from a crossing (fandisk seed 9 cut
//! 7 hole 552: 0.0002 from it, 0.002 edges); couplingdown_sharp #2's corners, which are inside
//! the hole (a chamfer's, 0.01 wide), lie 0.49-0.56 edges from theirs.
constexpr double kRimCornerEdges = 0.25;
//! The same for a rim vertex with no crossing: a corner this near it is on the rim. fandisk's
//! corner vertex left on the rim lies 0.012 mean rim edges from the creases' corner (crease slot
//! s5c8 hole 1326); couplingdown's chamfer corners, a hundredth wide and inside the hole, lie
//! within a quarter of a mean rim edge of rim vertices (with a quarter, crease slot s1c7 hole
//! 488's three-corner plan was refused, 1.04 -> 9.07 per mille crease distance).
constexpr double kRimVertexCornerEdges = 0.05;

bool join_at_corners(HoleCreasePlan& plan, const Mesh& mesh, const Hole& hole,
                     std::span<const std::size_t> crossings, double line_tolerance,
                     double two_corner_gain, const HermiteOptions& hermite, double tolerance,
                     const std::function<bool(const Vec3&)>& inside_hole) {
  FaceNormals normals(mesh, 16 * hole.loop.size());
  return join_at_corners(plan, normals, hole, crossings, line_tolerance, two_corner_gain, hermite,
                         tolerance, inside_hole,
                         [&] { return median_dihedral_near(mesh, hole, normals); });
}

bool join_at_corners(HoleCreasePlan& plan, FaceNormals& normals, const Hole& hole,
                     std::span<const std::size_t> crossings, double line_tolerance,
                     double two_corner_gain, const HermiteOptions& hermite, double tolerance,
                     const std::function<bool(const Vec3&)>& inside_hole,
                     const std::function<double()>& median_dihedral) {
  if (crossings.size() < 2) return false;
  const Mesh& mesh = normals.mesh();
  // Two corners need only lie near the rim's ball (RunCorners), not inside the hole's
  // projection.
  double rim_radius = 0;
  for (const VertexHandle v : hole.loop)
    rim_radius = std::max(rim_radius, (mesh.point(v) - hole.centroid).norm());
  // The runs' corners, worked out once for every search (the three-corner search's end runs
  // are the two-corner search's runs; the whole loop is one run).
  RunCorners runs(plan, crossings, line_tolerance, hole.centroid, rim_radius);
  const double mean_edge = hole.perimeter / static_cast<double>(hole.loop.size());
  // Corner k of \p joined is on the rim when it lies within kRimCornerEdges mean rim edges of
  // one of its creases' crossings (or of a crossing that add_corner gave no curve, the corner
  // being at its vertex): the cut went through the part's corner there, so the creases end at
  // that rim vertex (move_corner_to_rim), and curves to a point just off it bound needles.
  const auto crossing_at_corner = [&](const HoleCreasePlan& joined,
                                      std::size_t k) -> std::optional<std::size_t> {
    for (const std::size_t i : crossings) {
      bool member = true;
      for (const CreaseCurve& curve : joined.curves)
        if (curve.from == i) member = !curve.to && curve.corner == k;
      if (member &&
          (joined.corners[k] - plan.crossings[i].position).norm() < kRimCornerEdges * mean_edge)
        return i;
    }
    return std::nullopt;
  };
  const double half_edge = 0.5 * mean_edge;
  if (crossings.size() == 2) {
    // Two creases left over that no pair joins (a valley that ends at a ridge, fandisk crease
    // slot s9c4 hole 299) meet at a corner of their own if they are clean, their bent creases
    // meet inside the hole within the tolerance, and the corner is not on the rim (half a mean
    // rim edge from either crossing: there the creases end at a corner on the rim, and the
    // curve to the corner would be a sliver, 0.2°), on a CAD part's surroundings
    // (kCadMedianDihedralDeg: a hand scan's finger gaps took such corners and came out
    // farther, 3.6 -> 7.6 per mille).
    const RunCorners::Run& both = runs.at(0, 2);
    if (!both.corner || !runs.bends_are_fitted(both.crossings) || !inside_hole(*both.corner) ||
        both.farthest > line_tolerance)
      return false;
    for (const std::size_t i : both.crossings)
      if ((*both.corner - plan.crossings[i].position).norm() < half_edge) return false;
    if (!(median_dihedral() < kCadMedianDihedralDeg)) return false;
    add_corner(plan, both.crossings, *both.corner, hermite, tolerance);
    return true;
  }
  // Two corners fit more freely (each run's creases only), so they are taken only where they
  // fit far better: the creases, bent as fitted, pass at most `two_corner_gain` as far from
  // them as from the single corner (couplingdown_sharp #2: 0.23 of it). Four creases through
  // one point are rarer than two corners of three (a polyhedron's generic vertex).
  HoleCreasePlan one = plan;
  bool single = join_at_corner(one, crossings, line_tolerance, hermite, tolerance) &&
                inside_hole(one.corners.back());
  if (!single) {
    // A crease that curves into the corner misses it along its tangent line (fandisk: a slot
    // along a curved ridge up to where it meets two straight ones, the ridge's tangent line 0.11
    // from the corner, its bent crease 0.004), or the lines meet just outside the hole: the
    // creases bent as fitted meet there instead (RunCorners), if they are clean (a scan's rough
    // "creases" took a rocker-arm cut 9.1 -> 12.4 per mille).
    one = plan;
    const RunCorners::Run& whole = runs.at(0, crossings.size());
    if (whole.corner && runs.clean(whole.crossings) && inside_hole(*whole.corner)) {
      add_corner(one, whole.crossings, *whole.corner, hermite, tolerance);
      single = true;
    }
  }
  const double single_distance = single ? farthest_bent_crease(one, crossings, one.corners.back())
                                        : std::numeric_limits<double>::infinity();
  // Each further corner must again bring the creases within `two_corner_gain` of the distance
  // of the best plan with fewer.
  std::optional<HoleCreasePlan> best;
  double best_distance = std::numeric_limits<double>::infinity();
  if (single) {
    best = std::move(one);
    best_distance = single_distance;
  }
  HoleCreasePlan two = plan;
  double two_distance = 0;
  if (crossings.size() >= 4 &&
      join_at_two_corners(two, crossings, runs, hermite, tolerance, two_distance) &&
      two_distance <= two_corner_gain * best_distance) {
    best = std::move(two);
    best_distance = two_distance;
  }
  HoleCreasePlan three = plan;
  double three_distance = 0;
  if (crossings.size() >= 5 &&
      join_at_three_corners(three, mesh, hole, crossings, runs, hermite, tolerance,
                            two_corner_gain * best_distance, three_distance) &&
      three_distance <= two_corner_gain * best_distance) {
    best = std::move(three);
    best_distance = three_distance;
  }
  HoleCreasePlan four = plan;
  double four_distance = 0;
  if (crossings.size() >= 6 &&
      join_at_four_corners(four, mesh, hole, crossings, runs, hermite, tolerance,
                           two_corner_gain * best_distance, four_distance) &&
      four_distance <= two_corner_gain * best_distance) {
    best = std::move(four);
    best_distance = four_distance;
  }
  if (!best) return false;
  // A corner on the rim is that rim vertex; a middle corner of three (two links) on the rim is
  // no plan. The vertex may have no crossing of its own: the part's corner vertex left on the
  // rim with no sharp edge outside the hole (fandisk crease slot s5c8 hole 1326: the corner
  // 0.0012 from it, 0.46° needles); it gets one, as end_at_rim_corners gives a rim corner.
  const auto rim_vertex_near = [&](const Vec3& corner) -> std::optional<std::size_t> {
    std::optional<std::size_t> vertex;
    double nearest = kRimVertexCornerEdges * mean_edge;
    for (std::size_t j = 0; j < hole.loop.size(); ++j)
      if (const double d = (mesh.point(hole.loop[j]) - corner).norm(); d < nearest) {
        nearest = d;
        vertex = j;
      }
    return vertex;
  };
  const auto crossing_at_vertex = [](const HoleCreasePlan& joined,
                                     std::size_t j) -> std::optional<std::size_t> {
    for (std::size_t i = 0; i < joined.crossings.size(); ++i)
      if (joined.crossings[i].loop_index == j) return i;
    return std::nullopt;
  };
  // A crossing at rim vertex j where the creases of \p member's corner end, arriving straight.
  const auto add_rim_crossing = [&](HoleCreasePlan& joined, std::size_t j, std::size_t member) {
    const Vec3 position = mesh.point(hole.loop[j]);
    const CreaseCrossing& from = joined.crossings[member];
    joined.crossings.push_back(crossing_ending_at(from, j, hole.loop[j], position,
                                                  Vec3(from.position - position).normalize_cond(),
                                                  mean_edge));
    return joined.crossings.size() - 1;
  };
  for (std::size_t k = best->corners.size(); k-- > plan.corners.size();) {
    std::optional<std::size_t> at = crossing_at_corner(*best, k);
    if (!at) {
      const std::optional<std::size_t> j = rim_vertex_near(best->corners[k]);
      if (!j) continue;
      at = crossing_at_vertex(*best, *j);
      if (!at) {
        std::size_t member = crossings.front();
        for (const CreaseCurve& curve : best->curves)
          if (!curve.to && curve.corner == k) member = curve.from;
        at = add_rim_crossing(*best, *j, member);
      }
    }
    const auto links =
        std::count_if(best->corner_links.begin(), best->corner_links.end(),
                      [k](const auto& link) { return link.first == k || link.second == k; });
    if (links > 1) return false;
    move_corner_to_rim(*best, k, *at, hermite, tolerance);
  }
  plan = std::move(*best);
  return true;
}

namespace {

//! A rounded crease (a fillet) where it meets the rim: a run of consecutive boundary vertices,
//! close together, each with one soft edge leaving it in about the same direction, whose bends
//! add up to a crease's.
struct RoundedCrease {
  std::size_t first = 0, last = 0;  //!< loop indices of the run's ends (last after first)
  std::size_t middle = 0;           //!< the loop index where half the turn is reached
  HalfedgeHandle edge;              //!< the soft edge leaving the middle vertex
  double turn_deg = 0;              //!< the bends of the run's soft edges added up
};

//! The rounded creases at the rim of \p hole. A CAD part's fillet is a band of thin facets,
//! each bent by less than a crease's angle from the next (couplingdown_sml #1: three facets,
//! edges of 15-30°, turning the bore's wall into its ceiling), so no edge of it is sharp and the
//! plan would fill across it as across a smooth surface, cutting the corner (11.1‰ mean off;
//! the surfaces continued meet within 0.3 fillet radii of the band). Where the band crosses
//! the rim its facets' edges leave consecutive rim vertices a small fraction of the rim's mean
//! edge apart: a run of vertices each with exactly one edge bent by at least `kSoftEdgeDeg`
//! (and under the clean-crease angle: a chamfer's two 45° edges are two creases of their own),
//! the next vertex within `kBandGapShare` mean edges and within 1 / `kStripAspect` of either
//! edge's length (the facets are thin strips), the edges within `kBandSpreadDeg` of one
//! direction and folding the same way, their bends adding up to over the crease angle. A
//! scan's smooth surface, meshed evenly, has no such run: its rim vertices lie a mean edge apart
//! and its facets are not strips (on random cuts of the shared meshes only five fills of the
//! scanned cow changed, by at most 0.19‰ either way; README "Sharp edges").
std::vector<RoundedCrease> find_rounded_creases(FaceNormals& normals, const Hole& hole,
                                                const CreaseOptions& options) {
  constexpr double kSoftEdgeDeg = 8.0;
  constexpr double kBandGapShare = 0.5;
  constexpr double kStripAspect = 3.0;
  constexpr double kBandSpreadDeg = 30.0;
  const Mesh& mesh = normals.mesh();
  const std::size_t n = hole.loop.size();
  struct Member {
    HalfedgeHandle edge;
    double bend_deg = 0;
    bool convex = false;
    Vec3 direction{0, 0, 0};
    double length = 0;
  };
  std::vector<std::optional<Member>> members(n);
  for (std::size_t i = 0; i < n; ++i) {
    const VertexHandle b = hole.loop[i];
    const VertexHandle prev = hole.loop[(i + n - 1) % n];
    const VertexHandle next = hole.loop[(i + 1) % n];
    std::optional<Member> soft;
    bool clean = true;
    for (const HalfedgeHandle h : mesh.voh_range(b)) {
      const VertexHandle w = mesh.to_vertex_handle(h);
      if (w == prev || w == next || mesh.is_boundary(mesh.edge_handle(h))) continue;
      const double bend = dihedral_deg(normals, h);
      if (!(bend >= kSoftEdgeDeg)) continue;
      if (soft || bend >= options.clean_crease_angle_deg) {
        clean = false;
        break;
      }
      const Vec3 edge = mesh.point(w) - mesh.point(b);
      soft = Member{h, bend, folds_convex(normals, h), Vec3(edge).normalize_cond(), edge.norm()};
    }
    if (clean) members[i] = soft;
  }
  // Whether loop vertex k (a member) continues the run ending at j (a member) with \p head's
  // direction and fold.
  const double gap = kBandGapShare * hole.mean_edge_length;
  const double spread_cos = std::cos(kBandSpreadDeg * kDeg);
  const auto continues = [&](std::size_t j, std::size_t k, const Member& head) {
    if (!members[j] || !members[k] || members[k]->convex != head.convex ||
        OpenMesh::dot(members[k]->direction, head.direction) < spread_cos)
      return false;
    const double apart = (mesh.point(hole.loop[k]) - mesh.point(hole.loop[j])).norm();
    return apart <= gap && std::min(members[j]->length, members[k]->length) >= kStripAspect * apart;
  };
  // Runs start after a vertex that does not continue into them (a loop that is one whole run
  // has no start, and no crossing either).
  std::vector<RoundedCrease> out;
  for (std::size_t i = 0; i < n; ++i) {
    if (!members[i] || continues((i + n - 1) % n, i, *members[i])) continue;
    const Member& head = *members[i];
    std::vector<std::size_t> run{i};
    while (run.size() < n && continues(run.back(), (run.back() + 1) % n, head))
      run.push_back((run.back() + 1) % n);
    if (run.size() < 2) continue;
    double turn = 0;
    for (const std::size_t k : run) turn += members[k]->bend_deg;
    if (!(turn > options.crease_angle_deg)) continue;
    // The middle: the member whose share of the turn is centred nearest half of it.
    std::size_t middle = run.front();
    double before = 0, best = std::numeric_limits<double>::infinity();
    for (const std::size_t k : run) {
      const double centre = before + 0.5 * members[k]->bend_deg;
      if (std::abs(centre - 0.5 * turn) < best) {
        best = std::abs(centre - 0.5 * turn);
        middle = k;
      }
      before += members[k]->bend_deg;
    }
    out.push_back({run.front(), run.back(), middle, members[middle]->edge, turn});
  }
  return out;
}

//! "N crease crossings, K curves[ meeting at ...][, U unmatched]": the straight creases between
//! corners count as curves.
std::string plan_summary(const HoleCreasePlan& plan) {
  const auto plural = [](std::size_t count) { return count == 1 ? "" : "s"; };
  const std::size_t curves = curve_count(plan);
  return fmt::format(
      "{} crease crossing{}, {} curve{}{}{}", plan.crossings.size(), plural(plan.crossings.size()),
      curves, plural(curves), meeting_at_corners(plan.corners.size()),
      plan.unmatched.empty() ? "" : fmt::format(", {} unmatched", plan.unmatched.size()));
}

}  // namespace

HoleCreasePlan plan_hole_creases(const Mesh& mesh, const Hole& hole, const CreaseOptions& options) {
  // The faces around the boundary and along the creases.
  FaceNormals normals(mesh, 16 * hole.loop.size());
  return plan_hole_creases(normals, hole, options);
}

HoleCreasePlan plan_hole_creases(FaceNormals& normals, const Hole& hole,
                                 const CreaseOptions& options,
                                 std::optional<double> median_dihedral_deg) {
  const Mesh& mesh = normals.mesh();
  HoleCreasePlan plan;
  const std::size_t n = hole.loop.size();
  if (n < 3) return plan;
  const double diameter = hole.perimeter / std::numbers::pi;
  const double fit_length =
      crease_fit_length(hole.perimeter, hole.mean_edge_length, options.fit_length);
  const Vec3 normal = hole.is_simple ? hole.reference_normal : hole.normal;
  const ReferenceFrame frame = ReferenceFrame::from_normal(normal, hole.centroid);
  std::vector<Point2> polygon;
  for (const VertexHandle v : hole.loop) polygon.push_back(frame.project(mesh.point(v)));

  // Weaker sharp edges are candidates too, but only as partners of a strong crossing.
  const SharpAngle weak_angle(options.partner_angle_deg);
  std::vector<CreaseCrossing> found;
  // The crossing where the crease traced as \p polyline (points[0] the rim vertex at loop index
  // \p i) enters the hole, or none when it does not head strictly into the hole there.
  const auto crossing_from = [&](std::size_t i, const std::vector<Vec3>& polyline,
                                 HalfedgeHandle h) -> std::optional<CreaseCrossing> {
    const VertexHandle b = hole.loop[i];
    const VertexHandle prev = hole.loop[(i + n - 1) % n];
    const VertexHandle next = hole.loop[(i + 1) % n];
    CreaseShape shape = shape_of_crease(polyline, fit_length);
    if (!(shape.tangent.norm() > 0)) return std::nullopt;
    const Vec3 inward = -shape.tangent;
    const auto [phi, corner] = wedge_angles(vertex_normal(normals, b), mesh.point(prev),
                                            mesh.point(b), mesh.point(next), inward);
    // Strictly inside the hole's corner at b (a crease along the boundary is not a crossing).
    if (!(std::min(phi, corner - phi) > 0.0)) return std::nullopt;
    CreaseCrossing c;
    c.loop_index = i;
    c.vertex = b;
    c.position = mesh.point(b);
    c.inward = inward;
    c.curvature = shape.curvature;
    c.bend_inward = -shape.bend_tangent;
    c.near_rim = std::move(shape.near_rim);
    c.far_point = c.position - fit_length * inward;
    c.on_crease = polyline.back();
    double walked = 0;
    for (std::size_t k = 1; k < polyline.size(); ++k) {
      const double step = (polyline[k] - polyline[k - 1]).norm();
      if (walked + step >= fit_length) {
        c.on_crease =
            polyline[k - 1] + (fit_length - walked) / step * (polyline[k] - polyline[k - 1]);
        break;
      }
      walked += step;
    }
    const VertexHandle from = mesh.from_vertex_handle(h);
    c.dihedral_deg = dihedral_deg(normals, h);
    c.faces = {normals(mesh.face_handle(h)),
               normals(mesh.face_handle(mesh.opposite_halfedge_handle(h)))};
    for (const HalfedgeHandle o : mesh.voh_range(from))
      if (o != h && !mesh.is_boundary(mesh.edge_handle(o)))
        c.other_bends_deg = std::max(c.other_bends_deg, dihedral_deg(normals, o));
    c.convex = folds_convex(normals, h);
    c.traced_edges = polyline.size() - 1;
    return c;
  };
  // The crease traced as \p polyline (points[0] at loop index \p i) extended by the rim
  // vertices after i (in the direction \p step) that lie on its continuation, each predicted
  // from the tangent and curvature fitted by the rim: the loop index where the run ends, the
  // rim edges it took and the extended polyline (its rim end first).
  struct RimRun {
    std::size_t end, edges;
    std::vector<Vec3> polyline;
  };
  const auto rim_run_along = [&](std::size_t i, const std::vector<Vec3>& polyline,
                                 std::size_t step) {
    RimRun run{i, 0, polyline};
    while (run.edges + 2 < n) {
      const std::size_t k = (run.end + step) % n;
      const Vec3 q = mesh.point(hole.loop[k]);
      if (!continues_crease(run.polyline, q, fit_length, hole.mean_edge_length)) break;
      run.polyline.insert(run.polyline.begin(), q);
      run.end = k;
      ++run.edges;
    }
    return run;
  };
  // Whether the crease traced as \p polyline (points[0] at loop index \p j) goes on as a sharp
  // edge of the mesh at j: a crease that runs along the rim and then leaves it outwards (the
  // fitted continuation of a curved one may still point a little into the hole).
  const auto continues_outside = [&](std::size_t j, const std::vector<Vec3>& polyline) {
    const Vec3 ahead = -fit_bend(polyline, fit_length).tangent;
    for (const HalfedgeHandle o : mesh.voh_range(hole.loop[j])) {
      if (!is_sharp(normals, o, weak_angle)) continue;
      const Vec3 d = (mesh.point(mesh.to_vertex_handle(o)) - polyline[0]).normalize_cond();
      if (OpenMesh::dot(d, ahead) > std::cos(45.0 * kDeg)) return true;
    }
    return false;
  };
  for (std::size_t i = 0; i < n; ++i) {
    const VertexHandle b = hole.loop[i];
    const VertexHandle prev = hole.loop[(i + n - 1) % n];
    const VertexHandle next = hole.loop[(i + 1) % n];
    for (const HalfedgeHandle h : mesh.voh_range(b)) {
      const VertexHandle w = mesh.to_vertex_handle(h);
      if (w == prev || w == next || !is_sharp(normals, h, weak_angle)) continue;
      const std::vector<Vec3> polyline = trace_crease(normals, h, weak_angle, 4.0 * fit_length);
      // A crease that does not head into the hole where it meets the rim may run along the rim
      // and cross later, at a vertex with no sharp edge of its own (couplingdown_sharp #1: the
      // boss-top ring follows rim edge 7-8 and crosses the hole from 8): follow the rim while
      // its vertices lie on the crease's continuation; where the rim turns away the crease
      // crosses, unless it goes on outside the hole as a sharp edge there (couplingdown_sml #2:
      // a chamfer ring along rim vertices 0, 48, 47).
      if (auto c = crossing_from(i, polyline, h)) {
        found.push_back(std::move(*c));
        continue;
      }
      for (const std::size_t step : {std::size_t{1}, n - 1}) {
        const RimRun run = rim_run_along(i, polyline, step);
        if (run.edges == 0 || continues_outside(run.end, run.polyline)) continue;
        if (auto c = crossing_from(run.end, run.polyline, h)) {
          c->rim_run = run.edges;
          found.push_back(std::move(*c));
        }
      }
    }
  }
  // Rounded creases: one crossing each, at the band's middle, traced along its soft edge and
  // as strong as the band's whole turn (the crossings its members made alone are dropped).
  for (const RoundedCrease& band : find_rounded_creases(normals, hole, options)) {
    const auto in_band = [&](std::size_t k) {
      return (k + n - band.first) % n <= (band.last + n - band.first) % n;
    };
    std::erase_if(found, [&](const CreaseCrossing& c) { return in_band(c.loop_index); });
    const std::vector<Vec3> polyline = trace_crease(
        normals, band.edge, SharpAngle(0.5 * dihedral_deg(normals, band.edge)), 4.0 * fit_length);
    if (auto c = crossing_from(band.middle, polyline, band.edge)) {
      c->dihedral_deg = band.turn_deg;
      found.push_back(std::move(*c));
    }
  }

  // Clean pairs first, best (smallest worst angle) first, never interleaving in loop order. A
  // pair needs one strong end (over the crease angle; the other may be weaker, as a rounded scan
  // crease fades towards a hole) and one kind of fold: a ridge does not continue as a valley.
  const std::size_t m = found.size();
  const auto strong = [&](std::size_t i) {
    const CreaseCrossing& c = found[i];
    return c.dihedral_deg > options.crease_angle_deg ||
           (c.dihedral_deg > options.clean_crease_angle_deg && c.traced_edges >= 2 &&
            c.other_bends_deg <= options.clean_crease_ratio * c.dihedral_deg);
  };
  struct Candidate {
    double score;
    std::size_t a, b;
    std::optional<CreaseArc> arc;  //!< set when the pair is joined by an arc, not a line
    bool straight = false;         //!< joined by the chord itself (no fitted tangents)
    //! The pair's path across the hole: its arc sampled, or the chord its Hermite curve follows
    //! closely.
    std::vector<Vec3> path;
  };
  std::vector<Candidate> candidates;
  for (std::size_t a = 0; a < m; ++a)
    for (std::size_t b = a + 1; b < m; ++b) {
      const CreaseCrossing& ca = found[a];
      const CreaseCrossing& cb = found[b];
      const Vec3 chord = cb.position - ca.position;
      if (ca.loop_index == cb.loop_index || !(chord.norm() > 0) || ca.convex != cb.convex ||
          !(strong(a) || strong(b)))
        continue;
      if (strong(a) && strong(b) &&
          std::max(ca.dihedral_deg, cb.dihedral_deg) >
              options.max_pair_dihedral_ratio * std::min(ca.dihedral_deg, cb.dihedral_deg))
        continue;
      Candidate c{std::max(angle_between(ca.inward, chord), angle_between(cb.inward, -chord)),
                  a,
                  b,
                  std::nullopt,
                  false,
                  {}};
      // A curved crease: the arc both creases bend along, if it agrees better than the chord.
      // A crease that followed the rim may pair along an arc from a smaller turn on
      // (min_arc_turn_deg; couplingdown_sharp #1's boss-top ring crosses by 56°).
      double arc_score = 0;
      if (auto arc = crease_arc_between(ca, cb, min_arc_turn_deg(options, ca, cb),
                                        options.loose_pair_angle_deg, options.arc_curvature_factor,
                                        &arc_score);
          arc && arc_score < c.score) {
        c.score = arc_score;
        c.arc = arc;
      }
      // A crease that followed the rim: a ring (a boss's or a bore's edge) that runs along the
      // rim and then cuts across pairs along its arc (above). When both tangents lie along the
      // chord, the crease is straight and crosses a notch to the opposite rim, where the plain
      // fill's rim-to-rim edge already lies on it (fandisk_sml #1): the curve is the chord
      // itself, since fitted tangents would only add noise there. Otherwise its Hermite curve
      // joins the pair as any other: a crease that bends and then runs straight fits no arc
      // (fandisk's top edge, random cut s3c6 hole 1796: 56° of arc, then straight to the rim;
      // left unpaired, the 3D triangulation folded across it with 3.5° slivers).
      if ((ca.rim_run > 0 || cb.rim_run > 0) && !c.arc &&
          c.score <= options.rim_corner_angle_deg * kDeg)
        c.straight = true;
      if (c.arc) {
        for (int k = 0; k <= 16; ++k) c.path.push_back(c.arc->at(k / 16.0));
      } else {
        c.path = {ca.position, cb.position};
      }
      candidates.push_back(std::move(c));
    }
  std::sort(candidates.begin(), candidates.end(),
            [](const Candidate& x, const Candidate& y) { return x.score < y.score; });
  std::set<std::size_t> used_vertices;
  std::vector<Candidate> pairs;
  // Two curves that touch inside the hole cannot both be creases of one surface: the split
  // would make a non-manifold seam (couplingdown_sml #2: a ring found along the rim meets the
  // arc of two short chamfer creases near its middle). Ends on the rim are not compared.
  const auto pair_paths_meet = [&](const Candidate& x, const Candidate& y) {
    const std::vector<Vec3>& a = x.path;
    const std::vector<Vec3>& b = y.path;
    const double near = 0.25 * hole.mean_edge_length;
    const auto inside = [&](const Vec3& p, const Candidate& c) {
      return (p - found[c.a].position).norm() > near && (p - found[c.b].position).norm() > near;
    };
    // Segments farther apart than `near` along an axis are not measured (the paths are sampled
    // at the edge length, and most of their segment pairs lie far apart); the slack keeps every
    // pair the distance itself might count, rounded.
    const double apart = near * (1 + 1e-9);
    const auto far_apart = [apart](const Vec3& p, const Vec3& q, const Vec3& u, const Vec3& v) {
      for (int k = 0; k < 3; ++k)
        if (std::min(u[k], v[k]) - std::max(p[k], q[k]) > apart ||
            std::min(p[k], q[k]) - std::max(u[k], v[k]) > apart)
          return true;
      return false;
    };
    for (std::size_t i = 0; i + 1 < a.size(); ++i)
      for (std::size_t j = 0; j + 1 < b.size(); ++j) {
        if (far_apart(a[i], a[i + 1], b[j], b[j + 1])) continue;
        if (segment_segment_distance2(a[i], a[i + 1], b[j], b[j + 1]) > near * near) continue;
        if (inside(a[i], x) || inside(a[i + 1], x) || inside(b[j], y) || inside(b[j + 1], y))
          return true;
      }
    return false;
  };
  auto try_pair = [&](const Candidate& c, double limit) {
    const std::size_t la = found[c.a].loop_index, lb = found[c.b].loop_index;
    if (used_vertices.count(la) || used_vertices.count(lb) || c.score > limit) return;
    for (const Candidate& p : pairs)
      if (interleaved(la, lb, found[p.a].loop_index, found[p.b].loop_index) ||
          pair_paths_meet(c, p))
        return;
    used_vertices.insert(la);
    used_vertices.insert(lb);
    pairs.push_back(c);
  };
  // Strong crossings no pair took, the best (sharpest) per boundary vertex.
  const auto leftovers = [&] {
    std::map<std::size_t, std::size_t> best;  // loop index -> crossing
    for (std::size_t i = 0; i < m; ++i) {
      if (!strong(i) || used_vertices.count(found[i].loop_index)) continue;
      const auto it = best.find(found[i].loop_index);
      if (it == best.end() || found[i].dihedral_deg > found[it->second].dihedral_deg)
        best[found[i].loop_index] = i;
    }
    std::vector<std::size_t> out;
    for (const auto& [index, crossing] : best) out.push_back(crossing);
    return out;
  };
  for (const Candidate& c : candidates) try_pair(c, options.pair_angle_deg * kDeg);
  std::vector<std::size_t> left = leftovers();
  // The creases to a corner may not cross a paired curve: their crossings must all lie on one
  // side of every pair (couplingdown_sharp #2: a chamfer's pair runs between a corner's
  // creases).
  const auto one_side_of_every_pair = [&](const std::vector<std::size_t>& crossings) {
    for (const Candidate& p : pairs) {
      const std::size_t a = found[p.a].loop_index;
      const std::size_t span = (found[p.b].loop_index + n - a) % n;
      std::size_t inside = 0;
      for (const std::size_t i : crossings)
        inside += (found[i].loop_index + n - a) % n < span ? 1 : 0;
      if (inside != 0 && inside != crossings.size()) return false;
    }
    return true;
  };
  // One or two strong crossings left (a single crease, maybe strongly curved in the hole), or
  // more that cannot meet at a corner: a looser tangent agreement will do.
  bool corner_side_ok = one_side_of_every_pair(left);
  if (left.size() == 1 || left.size() == 2 || !corner_side_ok) {
    for (const Candidate& c : candidates) try_pair(c, options.loose_pair_angle_deg * kDeg);
    left = leftovers();
    corner_side_ok = one_side_of_every_pair(left);
  }
  // Report only the crossings that matter: those the curves use and strong ones left over.
  std::map<std::size_t, std::size_t> kept;  // index in found -> index in plan.crossings
  const auto keep = [&](std::size_t i) {
    const auto [it, added] = kept.emplace(i, plan.crossings.size());
    if (added) plan.crossings.push_back(found[i]);
    return it->second;
  };
  for (Candidate& p : pairs) {
    p.a = keep(p.a);
    p.b = keep(p.b);
  }
  for (std::size_t& i : left) i = keep(i);

  const double tolerance = 1e-9 * std::max(diameter, 1e-300);
  std::vector<Vec3> rim;
  for (const VertexHandle v : hole.loop) rim.push_back(mesh.point(v));
  for (const Candidate& p : pairs) {
    const CreaseCrossing& ca = plan.crossings[p.a];
    const CreaseCrossing& cb = plan.crossings[p.b];
    CreaseCurve curve;
    curve.from = p.a;
    curve.to = p.b;
    curve.points = {ca.far_point, ca.position, cb.position, cb.far_point};
    if (p.straight) curve.points = straight_curve_points(ca.position, cb.position);
    const HermiteCurveResult r = make_hermite_curve(curve.points, options.hermite, tolerance);
    if (!r.curve) continue;
    curve.curve = *r.curve;
    curve.arc = p.arc;
    curve.misfit = p.score;
    if (curve.arc) {
      const std::vector<ArcPiece> pieces =
          arc_pieces_across(*curve.arc, ca.loop_index, cb.loop_index, rim, hole.mean_edge_length);
      if (pieces.size() != 1 || pieces[0].loop_from != ca.loop_index ||
          pieces[0].loop_to != cb.loop_index) {
        // The ring meets the hole elsewhere than at the pair's crossings: each piece across
        // the hole is a curve of its own, between the boundary vertices where it leaves the
        // rim (crossings added for them, tangent and bend the arc's).
        const CreaseArc whole = *curve.arc;
        const CreaseCrossing model = ca;
        for (const ArcPiece& piece : pieces) {
          const CreaseArc part = sub_arc(whole, piece.from, piece.to);
          const auto crossing_at = [&](std::size_t loop_index, const Vec3& inward) {
            for (std::size_t x = 0; x < plan.crossings.size(); ++x)
              if (plan.crossings[x].loop_index == loop_index) return x;
            CreaseCrossing c = model;
            c.loop_index = loop_index;
            c.vertex = hole.loop[loop_index];
            c.position = rim[loop_index];
            c.inward = inward;
            c.far_point = c.position - crease_fit_length(hole.perimeter, hole.mean_edge_length,
                                                         options.fit_length) *
                                           inward;
            c.on_crease = c.position;
            c.curvature = (whole.centre - c.position) / (whole.radius * whole.radius);
            c.bend_inward = inward;  // the arc's own tangent, not the model crossing's fit
            c.near_rim = {c.position};
            c.traced_edges = 0;
            plan.crossings.push_back(c);
            return plan.crossings.size() - 1;
          };
          const Vec3 end_direction =
              -std::sin(part.angle) * (part.start - part.centre) / part.radius +
              std::cos(part.angle) * part.start_direction;
          CreaseCurve piece_curve;
          piece_curve.from = crossing_at(piece.loop_from, part.start_direction);
          piece_curve.to = crossing_at(piece.loop_to, -end_direction);
          const CreaseCrossing& pa = plan.crossings[piece_curve.from];
          const CreaseCrossing& pb = plan.crossings[*piece_curve.to];
          piece_curve.points = {pa.far_point, pa.position, pb.position, pb.far_point};
          const HermiteCurveResult hr =
              make_hermite_curve(piece_curve.points, options.hermite, tolerance);
          if (!hr.curve) continue;
          piece_curve.curve = *hr.curve;
          piece_curve.arc = part;
          piece_curve.misfit = p.score;
          plan.curves.push_back(piece_curve);
        }
        continue;
      }
    }
    plan.curves.push_back(curve);
  }

  // A corner must lie inside the hole's projection.
  const auto inside_hole = [&](const Vec3& p) {
    return point_in_polygon(polygon, frame.project(p));
  };
  MedianDihedral median_dihedral(normals, hole, median_dihedral_deg);
  const auto median = [&] { return median_dihedral(); };
  if (left.size() >= 3 && corner_side_ok &&
      join_at_corners(plan, normals, hole, left, options.corner_tolerance * diameter,
                      options.two_corner_gain, options.hermite, tolerance, inside_hole, median))
    left.clear();
  if (!left.empty())
    left =
        end_at_rim_corners(plan, normals, hole, left, SharpAngle(options.crease_angle_deg),
                           options.corner_tolerance * diameter, options.rim_corner_angle_deg * kDeg,
                           fit_length, options.hermite, tolerance);
  // Two creases left over that end at no corner on the rim may meet inside the hole.
  if (left.size() == 2 && plan.corners.empty() &&
      join_at_corners(plan, normals, hole, left, options.corner_tolerance * diameter,
                      options.two_corner_gain, options.hermite, tolerance, inside_hole, median))
    left.clear();
  if (left.size() >= 2)
    left =
        pair_along_shared_faces(plan, median_dihedral, hole, left, options, tolerance, inside_hole);
  left = end_on_paired_curves(plan, median_dihedral, hole, left,
                              options.corner_tolerance * diameter, options.hermite, tolerance);
  plan.unmatched = left;
  plan.summary = plan_summary(plan);
  return plan;
}

double median_dihedral_near(const Mesh& mesh, const Hole& hole, FaceNormals& normals) {
  std::vector<VertexHandle> ring(hole.loop.begin(), hole.loop.end());
  LocalSet seen_vertex(8 * ring.size());
  for (const VertexHandle v : ring) seen_vertex.insert(v.idx());
  std::size_t begin = 0;
  for (int r = 0; r < 2; ++r) {
    const std::size_t end = ring.size();
    for (std::size_t i = begin; i < end; ++i)
      for (const VertexHandle w : mesh.vv_range(ring[i]))
        if (seen_vertex.insert(w.idx())) ring.push_back(w);
    begin = end;
  }
  std::vector<double> cosines;
  LocalSet seen_edge(4 * ring.size());
  for (const VertexHandle v : ring)
    for (const HalfedgeHandle h : mesh.voh_range(v)) {
      const EdgeHandle e = mesh.edge_handle(h);
      if (mesh.is_boundary(e) || !seen_edge.insert(e.idx())) continue;
      cosines.push_back(normals.dihedral_cos(e));
    }
  if (cosines.empty()) return 0.0;
  // The median angle is the median cosine (the angle falls as the cosine rises); with the
  // descending order below, the element at size/2 is the same one a sort of angles picks.
  const auto mid = cosines.begin() + static_cast<std::ptrdiff_t>(cosines.size() / 2);
  std::nth_element(cosines.begin(), mid, cosines.end(), std::greater<>());
  return std::acos(std::clamp(*mid, -1.0, 1.0)) * 180.0 / std::numbers::pi;
}

std::string meeting_at_corners(std::size_t corners) {
  if (corners == 0) return "";
  return corners == 1 ? " meeting at a corner" : fmt::format(" meeting at {} corners", corners);
}

namespace {

//! \p out, \p plan with curves taken out, or none if it has no curve left; every crossing no
//! curve of it uses is reported unmatched, as a plan reports its own.
std::optional<HoleCreasePlan> with_unused_crossings_unmatched(const HoleCreasePlan& plan,
                                                              HoleCreasePlan out) {
  if (out.curves.empty()) return std::nullopt;
  std::vector<char> used(out.crossings.size(), 0);
  for (const CreaseCurve& c : out.curves) {
    used[c.from] = 1;
    if (c.to) used[*c.to] = 1;
  }
  for (const CreaseCurve& c : plan.curves)
    for (const std::optional<std::size_t> end : {std::optional<std::size_t>(c.from), c.to})
      if (end && !used[*end] &&
          std::find(out.unmatched.begin(), out.unmatched.end(), *end) == out.unmatched.end())
        out.unmatched.push_back(*end);
  out.summary = plan_summary(out);
  return out;
}

}  // namespace

std::optional<HoleCreasePlan> plan_without_weakest_curve(const HoleCreasePlan& plan,
                                                         const CreaseOptions& options,
                                                         const std::optional<Vec3>& failed_at) {
  std::optional<std::size_t> worst;
  bool drop_corners = false;
  if (failed_at) {
    // The curve (or corner link) that passes nearest the crossing.
    double nearest = std::numeric_limits<double>::infinity();
    const auto consider = [&](const Vec3& a, const Vec3& b, std::optional<std::size_t> curve) {
      const double d = segment_segment_distance2(*failed_at, *failed_at, a, b);
      if (d < nearest) {
        nearest = d;
        worst = curve;
        drop_corners = !curve || !plan.curves[*curve].to;
      }
    };
    constexpr int kSamples = 16;
    for (std::size_t i = 0; i < plan.curves.size(); ++i) {
      const CreaseCurve& c = plan.curves[i];
      const auto at = [&](int k) { return point_on(c, static_cast<double>(k) / kSamples); };
      for (int k = 0; k < kSamples; ++k) consider(at(k), at(k + 1), i);
    }
    for (const auto& [a, b] : plan.corner_links)
      consider(plan.corners[a], plan.corners[b], std::nullopt);
  } else {
    // The pairs by misfit (corner creases have none); a loose one goes before the corners.
    for (std::size_t i = 0; i < plan.curves.size(); ++i)
      if (plan.curves[i].to && (!worst || plan.curves[i].misfit > plan.curves[*worst].misfit))
        worst = i;
    drop_corners = !plan.corners.empty() &&
                   !(worst && plan.curves[*worst].misfit > options.pair_angle_deg * kDeg);
  }
  if (drop_corners) return plan_without_corners(plan);
  if (!worst) return std::nullopt;
  HoleCreasePlan out = plan;
  out.curves.erase(out.curves.begin() + static_cast<std::ptrdiff_t>(*worst));
  return with_unused_crossings_unmatched(plan, std::move(out));
}

std::optional<HoleCreasePlan> plan_without_corners(const HoleCreasePlan& plan) {
  if (plan.corners.empty()) return std::nullopt;
  // The corners go together: two or three in a row are one structure of creases.
  HoleCreasePlan out = plan;
  std::erase_if(out.curves, [](const CreaseCurve& c) { return !c.to; });
  out.curves.insert(out.curves.end(), out.pairs_split_at_corners.begin(),
                    out.pairs_split_at_corners.end());
  out.pairs_split_at_corners.clear();
  out.corners.clear();
  out.corner_links.clear();
  return with_unused_crossings_unmatched(plan, std::move(out));
}

std::vector<CurveSplitInput::Curve> sample_plan_curves(const HoleCreasePlan& plan,
                                                       double segment_length) {
  std::vector<CurveSplitInput::Curve> out;
  // Capped so a degenerate spacing cannot ask for an absurd count (the triangulation's own size
  // limit refuses far fewer).
  const auto segments_along = [&](double length) {
    return static_cast<std::size_t>(
        std::clamp(std::ceil(length / std::max(segment_length, 1e-300)), 1.0, 65536.0));
  };
  for (const CreaseCurve& c : plan.curves) {
    CurveSplitInput::Curve curve;
    curve.from = static_cast<int>(plan.crossings[c.from].loop_index);
    curve.to =
        c.to ? static_cast<int>(plan.crossings[*c.to].loop_index) : -1 - static_cast<int>(c.corner);
    if (c.arc) {
      const std::size_t segments = segments_along(c.arc->length());
      for (std::size_t i = 1; i < segments; ++i)
        curve.interior.push_back(c.arc->at(static_cast<double>(i) / segments));
    } else {
      const std::vector<CurveSample> samples = sample_by_arc_length(c.curve, segment_length);
      for (std::size_t i = 1; i + 1 < samples.size(); ++i)
        curve.interior.push_back(samples[i].point);
    }
    out.push_back(std::move(curve));
  }
  // A crease between two corners is straight (an edge of two planes, as the corners' creases
  // are fitted straight lines near them).
  for (const auto& [a, b] : plan.corner_links) {
    CurveSplitInput::Curve link;
    link.from = -1 - static_cast<int>(a);
    link.to = -1 - static_cast<int>(b);
    const Vec3 start = plan.corners[a], end = plan.corners[b];
    const std::size_t segments = segments_along((end - start).norm());
    for (std::size_t i = 1; i < segments; ++i)
      link.interior.push_back(start + (static_cast<double>(i) / segments) * (end - start));
    out.push_back(std::move(link));
  }
  return out;
}

namespace {

//! The largest angle of a region's triangles where the region can do without larger ones: on
//! the 38 holes of the cases 165° mends fandisk_sharp #1's 168° cap (smallest angle 5.2 ->
//! 11.3°) and changes nothing else but couplingdown_sml #1 (mean 11.60 -> 11.10 per mille);
//! 150-160° reshape couplingdown_sharp #2's wall for the worse (H 5.6 -> 18 per mille).
constexpr double kMaxRegionAngleDeg = 165;

//! Triangulates one region (pool indices, hole on the left).
bool triangulate_region(const std::vector<int>& region, const std::vector<Vec3>& pool,
                        const CurveSplitInput& input,
                        const std::vector<std::pair<int, int>>& shared_pairs,
                        std::vector<std::array<int, 3>>& triangles, std::string& failure) {
  const int loop_n = static_cast<int>(input.loop.size());
  const std::size_t k = region.size();
  std::vector<Vec3> points;
  std::vector<Vec3> opposite;
  for (std::size_t i = 0; i < k; ++i) points.push_back(pool[static_cast<std::size_t>(region[i])]);
  for (std::size_t i = 0; i < k; ++i) {
    const int a = region[i], b = region[(i + 1) % k];
    // A boundary edge of the hole has a mesh triangle across it; a curve edge has the other
    // region, still unknown: its midpoint makes the edge free in the dihedral weight.
    if (a < loop_n && b == (a + 1) % loop_n)
      opposite.push_back(input.opposite[static_cast<std::size_t>(a)]);
    else
      opposite.push_back(0.5 * (points[i] + points[(i + 1) % k]));
  }
  std::map<int, int> local;
  for (std::size_t i = 0; i < k; ++i) local[region[i]] = static_cast<int>(i);
  std::vector<std::pair<int, int>> blocked;
  std::vector<std::pair<int, int>> all_pairs(input.blocked.begin(), input.blocked.end());
  all_pairs.insert(all_pairs.end(), shared_pairs.begin(), shared_pairs.end());
  for (const auto& [a, b] : all_pairs) {
    const auto ia = local.find(a), ib = local.find(b);
    if (ia == local.end() || ib == local.end()) continue;
    const int x = ia->second, y = ib->second;
    const int gap = std::abs(x - y);
    if (gap == 1 || gap == static_cast<int>(k) - 1) continue;
    blocked.emplace_back(x, y);
  }
  auto emit = [&](const std::vector<std::array<int, 3>>& local_triangles) {
    for (const auto& t : local_triangles)
      triangles.push_back({region[static_cast<std::size_t>(t[0])],
                           region[static_cast<std::size_t>(t[1])],
                           region[static_cast<std::size_t>(t[2])]});
  };
  LiepaTriangulationOptions dp;
  dp.max_vertices = input.max_dp_vertices;
  // Needles along the rim first kept out (LiepaTriangulationOptions::max_angle_deg); a region
  // that cannot do without one takes it.
  dp.max_angle_deg = kMaxRegionAngleDeg;
  LiepaTriangulation t = triangulate_min_dihedral(points, opposite, blocked, dp);
  dp.max_angle_deg = 180;
  if (!t.ok) t = triangulate_min_dihedral(points, opposite, blocked, dp);
  if (t.ok) {
    emit(t.triangles);
    return true;
  }
  Vec3 newell(0, 0, 0), centroid(0, 0, 0);
  for (std::size_t i = 0; i < k; ++i) {
    newell += OpenMesh::cross(points[i], points[(i + 1) % k]);
    centroid += points[i] / static_cast<double>(k);
  }
  const ReferenceFrame frame = ReferenceFrame::from_normal(newell, centroid);
  std::vector<Point2> polygon;
  for (const Vec3& p : points) polygon.push_back(frame.project(p));
  if (count_self_intersections(polygon) == 0 && signed_area(polygon) > 0) {
    const PlanarTriangulation p = triangulate_planar(polygon, blocked);
    if (p.ok) {
      emit(p.triangles);
      return true;
    }
    failure = p.failure;
    return false;
  }
  failure = t.failure;
  return false;
}

}  // namespace

namespace {

//! attach_curves_to_boundary: a curve between neighbouring boundary vertices that stays within
//! this share of their edge's length of it is that edge. The region between them would be a
//! sliver no pass can mend, both sides being fixed (couplingdown crease slots along a boss's rim,
//! e.g. seed 14 cut 2 hole 734: a pair's curve bowed 0.0004 off a 0.041 rim edge, a 3.2°
//! triangle); a tenth keeps such a region's best triangle under 12°.
constexpr double kAlongEdgeShare = 0.1;

//! Where a curve passes (within a third of its sample spacing) by a boundary vertex other than
//! its ends, the crease runs through that vertex: the curve is cut there into two curves that
//! end on it (a piece joining two neighbouring boundary vertices is the boundary edge itself
//! and is dropped). Left as it was, the sample beside the boundary vertex would make a sliver
//! between the curve and the boundary that nothing downstream can mend, both being fixed.
std::vector<CurveSplitInput::Curve> attach_curves_to_boundary(const CurveSplitInput& input) {
  const int loop_n = static_cast<int>(input.loop.size());
  std::vector<CurveSplitInput::Curve> out;
  // A piece between two boundary vertices whose samples all lie within kAlongEdgeShare of an
  // edge's length off the boundary path between them (one way round or the other; a piece
  // between neighbours with no samples too) runs along the boundary that is already there: the
  // crease is the rim there (the cut followed it), and the piece adds nothing but slivers
  // between it and the rim. It is dropped.
  const auto along_rim = [&](int from, int steps, const std::vector<Vec3>& samples) {
    if (samples.empty()) return steps == 1;
    return std::all_of(samples.begin(), samples.end(), [&](const Vec3& p) {
      for (int k = 0; k < steps; ++k) {
        const Vec3& a = input.loop[static_cast<std::size_t>((from + k) % loop_n)];
        const Vec3& b = input.loop[static_cast<std::size_t>((from + k + 1) % loop_n)];
        const double limit = kAlongEdgeShare * (b - a).norm();
        if (segment_segment_distance2(p, p, a, b) <= limit * limit) return true;
      }
      return false;
    });
  };
  const auto emit = [&](CurveSplitInput::Curve c) {
    if (c.from >= 0 && c.to >= 0) {
      const int gap = ((c.to - c.from) % loop_n + loop_n) % loop_n;
      if (gap == 0) return;
      if (along_rim(c.from, gap, c.interior) || along_rim(c.to, loop_n - gap, c.interior)) return;
    }
    out.push_back(std::move(c));
  };
  const int corners = static_cast<int>(input.corners.size());
  const auto valid_end = [&](int end) { return end < loop_n && -1 - end < corners; };
  const auto point_of = [&](int end) {
    return end >= 0 ? input.loop[static_cast<std::size_t>(end)]
                    : input.corners[static_cast<std::size_t>(-1 - end)];
  };
  for (const auto& curve : input.curves) {
    if (!valid_end(curve.from) || !valid_end(curve.to)) {
      out.push_back(curve);  // refused below with a clear reason
      continue;
    }
    const Vec3 start = point_of(curve.from);
    const Vec3 end = point_of(curve.to);
    double length = 0;
    Vec3 previous = start;
    for (const Vec3& p : curve.interior) {
      length += (p - previous).norm();
      previous = p;
    }
    length += (end - previous).norm();
    const double reach = length / static_cast<double>(curve.interior.size() + 1) / 3.0;
    CurveSplitInput::Curve piece;
    piece.from = curve.from;
    for (const Vec3& p : curve.interior) {
      int touched = -1;
      double nearest = reach;
      for (int i = 0; i < loop_n; ++i) {
        const double d = (p - input.loop[static_cast<std::size_t>(i)]).norm();
        if (d < nearest) {
          nearest = d;
          touched = i;
        }
      }
      if (touched < 0) {
        piece.interior.push_back(p);
        continue;
      }
      if (touched == piece.from || touched == curve.to) continue;  // crowds its own end
      piece.to = touched;
      emit(piece);
      piece = CurveSplitInput::Curve{};
      piece.from = touched;
    }
    piece.to = curve.to;
    emit(piece);
  }
  return out;
}

}  // namespace

CurveSplitTriangulation triangulate_along_curves(const CurveSplitInput& original) {
  CurveSplitInput input = original;
  input.curves = attach_curves_to_boundary(original);
  CurveSplitTriangulation out;
  const int loop_n = static_cast<int>(input.loop.size());
  if (loop_n < 3) {
    out.failure = "fewer than 3 boundary vertices";
    return out;
  }
  std::vector<Vec3> pool(input.loop.begin(), input.loop.end());
  auto add_point = [&](const Vec3& p) {
    pool.push_back(p);
    out.new_points.push_back(p);
    return static_cast<int>(pool.size()) - 1;
  };
  // Corner k is pool node corner_node[k]; a curve end -1 - k names it.
  std::vector<int> corner_node;
  for (const Vec3& c : input.corners) corner_node.push_back(add_point(c));
  const int corners = static_cast<int>(corner_node.size());
  const auto node_of = [&](int end) {
    return end >= 0 ? end : corner_node[static_cast<std::size_t>(-1 - end)];
  };
  // Undirected adjacency of the graph: boundary edges and curve edges.
  std::map<int, std::set<int>> neighbours;
  for (int i = 0; i < loop_n; ++i) {
    neighbours[i].insert((i + 1) % loop_n);
    neighbours[(i + 1) % loop_n].insert(i);
  }
  std::set<std::pair<int, int>> directed;  // half-edges with a region on their left
  std::vector<std::pair<int, int>> shared_pairs;
  for (int i = 0; i < loop_n; ++i) directed.insert({i, (i + 1) % loop_n});
  for (const auto& curve : input.curves) {
    // From the rim to the rim or a corner, or between two corners.
    const bool link = curve.from < 0;
    if (curve.from >= loop_n || curve.to >= loop_n || -1 - curve.from >= corners ||
        -1 - curve.to >= corners || (link && curve.to >= 0) || curve.from == curve.to) {
      out.failure = "a curve does not start and end on the hole boundary or at a corner";
      return out;
    }
    std::vector<int> chain{node_of(curve.from)};
    for (const Vec3& p : curve.interior) chain.push_back(add_point(p));
    chain.push_back(node_of(curve.to));
    // Two nodes of one curve lie on both regions beside it: an edge between them in both
    // would have four faces, so neither region may join them.
    for (std::size_t x = 0; x < chain.size(); ++x)
      for (std::size_t y = x + 2; y < chain.size(); ++y)
        shared_pairs.emplace_back(chain[x], chain[y]);
    if (chain.size() == 2 && neighbours[chain[0]].count(chain[1])) {
      out.failure = "a curve joins two neighbouring boundary vertices";
      return out;
    }
    for (std::size_t i = 0; i + 1 < chain.size(); ++i) {
      const int a = chain[i], b = chain[i + 1];
      if (!directed.insert({a, b}).second || !directed.insert({b, a}).second) {
        out.failure = "two curves share an edge";
        return out;
      }
      neighbours[a].insert(b);
      neighbours[b].insert(a);
      out.curve_edges.emplace_back(a, b);
    }
  }
  // Faces of the planar graph, traced combinatorially (a projection can fold curves of a hole
  // around a corner over each other). Around a boundary vertex i the hole's side runs
  // counter-clockwise from i+1 to i-1, and a curve to j comes before one to k when j is nearer
  // i+1 along the loop; around a corner the curves come in loop order of their rim ends, and a
  // crease to another corner where that corner's rim ends are (they lie between two of this
  // corner's, or the curves would cross). Leaving v after arriving from u, the region on the
  // left continues to u's clockwise neighbour at v.
  std::map<int, std::vector<int>> ccw;  // node -> neighbours counter-clockwise
  {
    std::map<int, std::vector<std::pair<int, int>>> curve_starts;  // loop vertex -> (key, nbr)
    // corner -> (loop index of a rim end, neighbour); a link waits for its other corner's.
    std::vector<std::vector<std::pair<int, int>>> corner_members(corner_node.size());
    std::vector<int> rim_end_of_corner(corner_node.size(), -1);
    std::vector<std::pair<int, std::pair<int, int>>> links;  // (corner, (other corner, nbr))
    // The rim ends of each corner's curves: a curve from a rim vertex to a corner comes, among
    // the vertex's other curves, where the corner's other rim ends are (a corner on the rim moved
    // there by move_corner_to_rim leaves a rim vertex with curves both to the rim and to a
    // corner).
    std::vector<std::vector<int>> corner_rim_ends(corner_node.size());
    for (const auto& curve : input.curves)
      if (curve.from >= 0 && curve.to < 0)
        corner_rim_ends[static_cast<std::size_t>(-1 - curve.to)].push_back(curve.from);
    const auto corner_key = [&](int from, int corner) {
      for (const int end : corner_rim_ends[static_cast<std::size_t>(corner)])
        if (end != from) return ((end - from) % loop_n + loop_n) % loop_n;
      return loop_n;  // no other rim end: after the vertex's other curves
    };
    int next_new = loop_n + corners;
    for (const auto& curve : input.curves) {
      const int k = static_cast<int>(curve.interior.size());
      const int first = k > 0 ? next_new : node_of(curve.to);
      const int last = k > 0 ? next_new + k - 1 : node_of(curve.from);
      if (curve.from < 0) {
        links.push_back({-1 - curve.from, {-1 - curve.to, first}});
        links.push_back({-1 - curve.to, {-1 - curve.from, last}});
      } else {
        const int forward = curve.to >= 0 ? ((curve.to - curve.from) % loop_n + loop_n) % loop_n
                                          : corner_key(curve.from, -1 - curve.to);
        curve_starts[curve.from].emplace_back(forward, first);
        if (curve.to >= 0) {
          const int back = ((curve.from - curve.to) % loop_n + loop_n) % loop_n;
          curve_starts[curve.to].emplace_back(back, last);
        } else {
          const std::size_t c = static_cast<std::size_t>(-1 - curve.to);
          corner_members[c].emplace_back(curve.from, last);
          rim_end_of_corner[c] = curve.from;
        }
      }
      for (int j = 0; j < k; ++j) {
        const int node = next_new + j;
        const int before = j == 0 ? node_of(curve.from) : node - 1;
        const int after = j + 1 < k ? node + 1 : node_of(curve.to);
        ccw[node] = {before, after};
      }
      next_new += k;
    }
    for (const auto& [c, link] : links) {
      const int key = rim_end_of_corner[static_cast<std::size_t>(link.first)];
      if (key < 0) {
        out.failure =
            "a crease between two corners ends at a corner no crease from the rim reaches";
        return out;
      }
      corner_members[static_cast<std::size_t>(c)].emplace_back(key, link.second);
    }
    for (int i = 0; i < loop_n; ++i) {
      std::vector<int>& order = ccw[i];
      order.push_back((i + 1) % loop_n);
      auto starts = curve_starts[i];
      std::sort(starts.begin(), starts.end());
      for (const auto& [key, neighbour] : starts) order.push_back(neighbour);
      order.push_back((i + loop_n - 1) % loop_n);
    }
    for (std::size_t c = 0; c < corner_node.size(); ++c) {
      std::sort(corner_members[c].begin(), corner_members[c].end());
      for (const auto& [index, neighbour] : corner_members[c])
        ccw[corner_node[c]].push_back(neighbour);
    }
  }
  auto next_after = [&](int u, int v) {
    const std::vector<int>& order = ccw[v];
    const auto it = std::find(order.begin(), order.end(), u);
    if (it == order.end() || order.size() < 2) return -1;
    const std::size_t at = static_cast<std::size_t>(it - order.begin());
    return order[(at + order.size() - 1) % order.size()];
  };
  std::set<std::pair<int, int>> remaining = directed;
  std::vector<std::vector<int>> regions;
  while (!remaining.empty()) {
    const auto start = *remaining.begin();
    std::vector<int> region;
    auto edge = start;
    while (true) {
      if (!remaining.erase(edge)) {
        out.failure = "the curves do not split the hole into regions (they cross or leave it)";
        return out;
      }
      region.push_back(edge.first);
      const int w = next_after(edge.first, edge.second);
      if (w < 0) {
        out.failure = "a curve ends inside the hole";
        return out;
      }
      edge = {edge.second, w};
      if (edge == start) break;
      if (region.size() > pool.size() * 2) {
        out.failure = "region tracing did not close";
        return out;
      }
    }
    if (region.size() < 3) {
      out.failure = "two curves enclose no area";
      return out;
    }
    regions.push_back(std::move(region));
  }
  for (std::size_t r = 0; r < regions.size(); ++r) {
    std::string why;
    if (!triangulate_region(regions[r], pool, input, shared_pairs, out.triangles, why)) {
      out.failure = fmt::format("region {} of {}: {}", r + 1, regions.size(), why);
      out.triangles.clear();
      return out;
    }
    out.piece_of_triangle.resize(out.triangles.size(), static_cast<int>(r));
  }
  out.pieces = regions.size();
  out.ok = true;
  return out;
}

}  // namespace touchmend::geometry
