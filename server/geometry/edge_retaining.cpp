#include "server/geometry/edge_retaining.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <set>
#include <vector>

#include "server/geometry/face_set.h"
#include "server/geometry/fairing.h"
#include "server/geometry/mesh_intersections.h"
#include "server/geometry/patch_quality.h"

namespace touchmend::geometry {
namespace {

//! The polyline point at parameter t (segment index + fraction): the sampled curve, which is
//! what the curtain is made of.
Vec3 polyline_point(const GuideSurface& guide, double t) {
  const std::size_t last = guide.samples.size() - 1;
  const double clamped = std::clamp(t, 0.0, static_cast<double>(last));
  const std::size_t k = std::min(static_cast<std::size_t>(clamped), last == 0 ? 0 : last - 1);
  const double mu = clamped - static_cast<double>(k);
  if (last == 0) return guide.samples[0].point;
  return (1 - mu) * guide.samples[k].point + mu * guide.samples[k + 1].point;
}

Vec3 curtain_position(const GuideSurface& guide, const CurtainPoint& c) {
  return polyline_point(guide, c.t) + c.s * guide.normal;
}

//! Crossing of the 2D segment [a, b] with the polyline: edge parameter λ and polyline
//! parameter t of the first proper crossing.
std::optional<std::pair<double, double>> cross_polyline(const GuideSurface& guide, const Point2& a,
                                                        const Point2& b) {
  for (std::size_t k = 0; k + 1 < guide.polyline.size(); ++k) {
    const Point2& c = guide.polyline[k];
    const Point2& d = guide.polyline[k + 1];
    const double d1 = orient2d(c, d, a), d2 = orient2d(c, d, b);
    const double d3 = orient2d(a, b, c), d4 = orient2d(a, b, d);
    if ((d1 > 0) == (d2 > 0) || d1 == 0 || d2 == 0) continue;
    if ((d3 > 0) == (d4 > 0) && d3 != 0 && d4 != 0) continue;
    const double lambda = d1 / (d1 - d2);
    const double mu = d3 / (d3 - d4);
    if (!(mu >= 0 && mu <= 1)) continue;
    return std::make_pair(lambda, static_cast<double>(k) + mu);
  }
  return std::nullopt;
}

//! Signed area of a face seen along the guide's normal, with \p v at \p at.
double projected_area(const Mesh& mesh, const GuideSurface& guide, FaceHandle f, VertexHandle v,
                      const Vec3& at) {
  Point2 p[3];
  int k = 0;
  for (const VertexHandle w : mesh.fv_range(f))
    p[k++] = guide.frame.project(w == v ? at : mesh.point(w));
  return orient2d(p[0], p[1], p[2]);
}

bool move_keeps_orientation(const Mesh& mesh, const GuideSurface& guide, const FaceSet& patch,
                            VertexHandle v, const Vec3& to) {
  for (const FaceHandle f : mesh.vf_range(v)) {
    if (!patch.contains(f)) continue;
    const double before = projected_area(mesh, guide, f, v, mesh.point(v));
    const double after = projected_area(mesh, guide, f, v, to);
    if (before == 0 || (before > 0) != (after > 0) || std::abs(after) < 1e-6 * std::abs(before))
      return false;
  }
  return true;
}

}  // namespace

std::vector<std::array<Vec3, 3>> GuideSurface::triangles() const {
  std::vector<std::array<Vec3, 3>> out;
  for (std::size_t k = 0; k + 1 < samples.size(); ++k) {
    const Vec3 a = samples[k].point - height * normal, b = samples[k + 1].point - height * normal;
    const Vec3 c = samples[k + 1].point + height * normal, d = samples[k].point + height * normal;
    out.push_back({a, b, c});
    out.push_back({a, c, d});
  }
  return out;
}

GuideSurface make_guide_surface(const HermiteCurve& curve, const Vec3& normal,
                                double segment_length, double height) {
  GuideSurface g;
  g.curve = curve;
  g.normal = Vec3(normal).normalize_cond();
  g.height = height;
  g.samples = sample_by_arc_length(curve, segment_length);
  g.frame = ReferenceFrame::from_normal(g.normal, curve.start);
  for (const CurveSample& s : g.samples) g.polyline.push_back(g.frame.project(s.point));
  return g;
}

std::optional<CurtainPoint> curtain_coordinates(const GuideSurface& guide, const Vec3& p,
                                                double tolerance) {
  const Point2 q = guide.frame.project(p);
  double best = std::numeric_limits<double>::infinity();
  CurtainPoint out;
  for (std::size_t k = 0; k + 1 < guide.polyline.size(); ++k) {
    const Point2 a = guide.polyline[k], b = guide.polyline[k + 1];
    const Point2 ab = b - a;
    const double len2 = ab.squaredNorm();
    const double mu = len2 > 0 ? std::clamp((q - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
    const double d = (a + mu * ab - q).norm();
    if (d < best) {
      best = d;
      out.t = static_cast<double>(k) + mu;
    }
  }
  if (!(best <= tolerance)) return std::nullopt;
  out.s = OpenMesh::dot(p - polyline_point(guide, out.t), guide.normal);
  out.side = out.s > 0 ? 1 : (out.s < 0 ? -1 : 0);
  return out;
}

SnapReport snap_to_guide(Mesh& mesh, SharpEdgeState& state, const SnapOptions& options) {
  SnapReport report;
  const GuideSurface& guide = state.guide;
  FaceSet patch(state.patch);
  const auto is_boundary = [&](VertexHandle v) { return state.boundary.count(v.idx()) > 0; };
  const auto on_guide = [&](VertexHandle v) { return state.on_guide.count(v.idx()) > 0; };
  const auto join = [&](VertexHandle v, const Vec3& at, double t) {
    CurtainPoint c;
    c.t = t;
    c.s = OpenMesh::dot(at - polyline_point(guide, t), guide.normal);
    c.side = c.s > 0 ? 1 : (c.s < 0 ? -1 : 0);
    state.on_guide[v.idx()] = c;
  };
  const auto interior_edge = [&](EdgeHandle e) {
    const HalfedgeHandle h0 = mesh.halfedge_handle(e, 0), h1 = mesh.halfedge_handle(e, 1);
    return patch.contains(mesh.face_handle(h0)) && patch.contains(mesh.face_handle(h1));
  };
  struct Crossing {
    EdgeHandle edge;
    VertexHandle nearer;
    Vec3 point;
    double t;
    double displacement;
  };
  const auto find_crossings = [&] {
    std::vector<Crossing> out;
    std::set<int> seen;
    for (const FaceHandle f : state.patch) {
      if (mesh.status(f).deleted()) continue;
      for (const HalfedgeHandle h : mesh.fh_range(f)) {
        const EdgeHandle e = mesh.edge_handle(h);
        if (!seen.insert(e.idx()).second) continue;
        const VertexHandle a = mesh.from_vertex_handle(h), b = mesh.to_vertex_handle(h);
        if (on_guide(a) || on_guide(b)) continue;
        const auto hit = cross_polyline(guide, guide.frame.project(mesh.point(a)),
                                        guide.frame.project(mesh.point(b)));
        if (!hit) continue;
        const Vec3 x = mesh.point(a) + hit->first * (mesh.point(b) - mesh.point(a));
        const double da = (x - mesh.point(a)).norm(), db = (x - mesh.point(b)).norm();
        out.push_back({e, da <= db ? a : b, x, hit->second, std::min(da, db)});
      }
    }
    return out;
  };
  const auto split_at = [&](const Crossing& c) {
    if (!interior_edge(c.edge)) return false;  // a hole boundary edge: the mesh stays as it is
    const VertexHandle v = mesh.split(c.edge, c.point);
    for (const FaceHandle f : mesh.vf_range(v))
      if (!patch.contains(f)) {
        patch.insert(f);
        state.patch.push_back(f);
      }
    report.new_vertices.push_back(v);
    join(v, c.point, c.t);
    ++report.splits;
    return true;
  };

  // Vertices already on the curtain (a symmetric patch has them) join it as they are.
  double scale = 0;
  for (const CurveSample& sample : guide.samples)
    scale = std::max(scale, (sample.point - guide.samples.front().point).norm());
  for (const FaceHandle f : state.patch) {
    if (mesh.status(f).deleted()) continue;
    for (const VertexHandle v : mesh.fv_range(f)) {
      if (is_boundary(v) || on_guide(v)) continue;
      if (const auto c = curtain_coordinates(guide, mesh.point(v), 1e-9 * std::max(scale, 1e-300));
          c && c->t > 0 && c->t < static_cast<double>(guide.samples.size() - 1))
        state.on_guide[v.idx()] = *c;
    }
  }
  std::vector<Crossing> crossings = find_crossings();
  report.crossings = crossings.size();
  if (options.mode != SnapMode::Split) {
    // Per vertex, the crossing with the smallest displacement among the edges it is the nearer
    // end of; vertices in id order (ALGORITHMS.md §3.2: deterministic, no overwrites).
    std::map<int, const Crossing*> best;
    for (const Crossing& c : crossings) {
      if (is_boundary(c.nearer)) continue;
      auto [it, added] = best.emplace(c.nearer.idx(), &c);
      if (!added && c.displacement < it->second->displacement) it->second = &c;
    }
    for (const auto& [index, c] : best) {
      const VertexHandle v(index);
      if (on_guide(v)) continue;
      if (options.mode == SnapMode::Auto &&
          !move_keeps_orientation(mesh, guide, patch, v, c->point))
        continue;  // split below instead
      mesh.set_point(v, c->point);
      join(v, c->point, c->t);
      ++report.moved;
    }
  }
  if (options.mode != SnapMode::Move) {
    // Edges that still cross (boundary-to-boundary chords, refused moves): split them.
    for (int pass = 0; pass < 4; ++pass) {
      const std::vector<Crossing> left = find_crossings();
      bool any = false;
      for (const Crossing& c : left) {
        if (mesh.status(c.edge).deleted()) continue;
        const VertexHandle a = mesh.from_vertex_handle(mesh.halfedge_handle(c.edge, 0));
        const VertexHandle b = mesh.to_vertex_handle(mesh.halfedge_handle(c.edge, 0));
        if (on_guide(a) || on_guide(b)) continue;
        any = split_at(c) || any;
      }
      if (!any) break;
    }
  }
  // Join consecutive curtain vertices by an edge where one flip does it, so a crease can run
  // along them.
  std::vector<std::pair<double, int>> chain;
  for (const auto& [index, c] : state.on_guide)
    if (!mesh.status(VertexHandle(index)).deleted()) chain.emplace_back(c.t, index);
  std::sort(chain.begin(), chain.end());
  for (std::size_t i = 0; i + 1 < chain.size(); ++i) {
    const VertexHandle u(chain[i].second), w(chain[i + 1].second);
    if (mesh.find_halfedge(u, w).is_valid()) continue;
    for (const HalfedgeHandle h : mesh.voh_range(u)) {
      // The edge opposite u in face (u, x, y): flipping it joins u to the vertex beyond.
      if (mesh.is_boundary(h)) continue;
      const HalfedgeHandle opposite_edge = mesh.next_halfedge_handle(h);
      const EdgeHandle e = mesh.edge_handle(opposite_edge);
      if (!interior_edge(e)) continue;
      const HalfedgeHandle twin = mesh.opposite_halfedge_handle(opposite_edge);
      if (mesh.to_vertex_handle(mesh.next_halfedge_handle(twin)) != w) continue;
      if (!mesh.is_flip_ok(e)) continue;
      // The two new triangles must keep their orientation seen along the normal.
      const Point2 pu = guide.frame.project(mesh.point(u)), pw = guide.frame.project(mesh.point(w));
      const Point2 px = guide.frame.project(mesh.point(mesh.from_vertex_handle(opposite_edge)));
      const Point2 py = guide.frame.project(mesh.point(mesh.to_vertex_handle(opposite_edge)));
      if ((orient2d(pu, px, pw) > 0) == (orient2d(pu, py, pw) > 0)) continue;
      mesh.flip(e);
      ++report.flips;
      break;
    }
  }
  return report;
}

PushResult push_down(Mesh& mesh, SharpEdgeState& state, const Vec3& proxy,
                     const Vec3& previous_proxy, FaceHandle touched, const PushOptions& options) {
  PushResult r;
  const Vec3 motion = proxy - previous_proxy;
  if (!(motion.norm() > 1e-12)) {
    r.why_not = "the tool did not move (a sweep needs a direction)";
    return r;
  }
  if (!(options.step > 0) || !std::isfinite(options.step)) {
    r.why_not = "the step distance must be positive";
    return r;
  }
  FaceSet patch(state.patch);
  if (!touched.is_valid() || static_cast<std::size_t>(touched.idx()) >= mesh.n_faces() ||
      mesh.status(touched).deleted() || !patch.contains(touched)) {
    r.why_not = "the touched triangle is not part of the filled hole";
    return r;
  }
  const Vec3 direction = motion / motion.norm();
  // Of the touched face's curtain vertices, the nearest to the line of motion that can still
  // move (a vertex already at its limit is passed over for the next one).
  const auto limit_of = [&](const CurtainPoint& c) {
    const int side = c.side != 0 ? c.side : (c.s >= 0 ? 1 : -1);
    return std::pair{side, -side * std::max(0.0, options.depth)};
  };
  bool any_on_guide = false;
  bool any_blocked = false;
  std::set<int> seen;
  // The curtain vertices of \p faces still short of their limit, nearest the line first.
  const auto candidates_of = [&](const std::vector<FaceHandle>& faces) {
    std::vector<std::pair<double, VertexHandle>> out;
    for (const FaceHandle f : faces)
      for (const VertexHandle v : mesh.fv_range(f)) {
        const auto it = state.on_guide.find(v.idx());
        if (it == state.on_guide.end()) continue;
        any_on_guide = true;
        if (!seen.insert(v.idx()).second) continue;
        const auto [side, limit] = limit_of(it->second);
        if (side * (it->second.s - limit) <= 0) continue;  // already there
        out.emplace_back(OpenMesh::cross(mesh.point(v) - proxy, direction).norm(), v);
      }
    std::stable_sort(out.begin(), out.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    return out;
  };
  // One step of \p v along the curtain. [ours] Two curtain vertices at nearly the same place
  // along the curve meet there once both are pushed down, and the triangle between them and a
  // third vertex becomes a needle (random picks: 0.004° and 0.03° in 2 of about 2,400
  // push-downs). A step that would make one (or make one there worse) is not taken: the vertex
  // stays where it was, a little above the curve, and the next candidate is tried.
  const auto step_vertex = [&](VertexHandle v) {
    CurtainPoint& c = state.on_guide[v.idx()];
    const auto [side, limit] = limit_of(c);
    double s = c.s - side * options.step;
    bool at_limit = false;
    if (side * (s - limit) <= 0) {
      s = limit;
      at_limit = true;
    }
    const Vec3 from = mesh.point(v);
    std::vector<FaceHandle> around;
    for (const FaceHandle f : mesh.vf_range(v)) around.push_back(f);
    const double worst_before = min_angle_deg(mesh, around);
    const double s_before = c.s;
    c.s = s;
    const Vec3 to = curtain_position(state.guide, c);
    mesh.set_point(v, to);
    if (const double worst = min_angle_deg(mesh, around);
        worst < kDegenerateAngleDeg && worst < worst_before) {
      mesh.set_point(v, from);
      c.s = s_before;
      any_blocked = true;
      return false;
    }
    r.vertex = v;
    r.from = from;
    r.to = to;
    r.at_limit = at_limit;
    return true;
  };
  const auto try_in_order = [&](const std::vector<std::pair<double, VertexHandle>>& list) {
    for (const auto& [distance, v] : list)
      if (step_vertex(v)) return true;
    return false;
  };
  bool stepped = try_in_order(candidates_of({touched}));
  // [ours] Every curtain vertex of the touched triangle is done (or blocked): the nearest one
  // still to go among the patch triangles around it, so a sweep over a finished stretch keeps
  // working where the curtain is still short of the curve (the thesis' rule alone leaves most
  // samples of a sweep without effect once the first vertices are down).
  if (!stepped) {
    std::vector<FaceHandle> around;
    for (const VertexHandle corner : mesh.fv_range(touched))
      for (const FaceHandle f : mesh.vf_range(corner))
        if (f != touched && patch.contains(f)) around.push_back(f);
    stepped = try_in_order(candidates_of(around));
  }
  if (!stepped) {
    if (any_blocked)
      r.why_not =
          "a step would leave a degenerate triangle at every vertex still to go here (another "
          "curtain vertex is already at the same place on the curve)";
    else if (any_on_guide)
      r.why_not = "the touched triangle's vertices (and its neighbours') are already at the curve";
    else
      r.why_not = "the touched triangle has no vertex on the guiding surface";
    r.at_limit = any_on_guide && !any_blocked;
    return r;
  }
  state.moved.insert(r.vertex.idx());
  r.moved = true;
  return r;
}

std::size_t push_all(Mesh& mesh, SharpEdgeState& state, const PushOptions& options) {
  std::size_t moved = 0;
  for (auto& [index, c] : state.on_guide) {
    const int side = c.side != 0 ? c.side : (c.s >= 0 ? 1 : -1);
    const double limit = -side * std::max(0.0, options.depth);
    if (side * (c.s - limit) <= 0) continue;
    c.s = limit;
    mesh.set_point(VertexHandle(index), curtain_position(state.guide, c));
    state.moved.insert(index);
    ++moved;
  }
  return moved;
}

SmoothReport smooth_by_normal_propagation(Mesh& mesh, const SharpEdgeState& state) {
  SmoothReport report;
  const FaceSet patch(state.patch);
  std::set<int> fixed(state.boundary.begin(), state.boundary.end());
  for (const auto& [index, c] : state.on_guide) fixed.insert(index);
  fixed.insert(state.moved.begin(), state.moved.end());
  std::set<int> free_vertices;
  for (const FaceHandle f : state.patch) {
    if (mesh.status(f).deleted()) continue;
    for (const VertexHandle v : mesh.fv_range(f))
      if (!fixed.count(v.idx())) free_vertices.insert(v.idx());
  }
  // N_v: boundary vertices take the surrounding surface's normals (the thesis' N_i), every
  // other fixed vertex the mean normal of its fixed patch triangles.
  const auto fixed_face = [&](FaceHandle f) {
    for (const VertexHandle v : mesh.fv_range(f))
      if (!fixed.count(v.idx())) return false;
    return true;
  };
  const auto vertex_normal = [&](VertexHandle v) -> std::optional<Vec3> {
    Vec3 sum(0, 0, 0);
    const bool on_boundary = state.boundary.count(v.idx()) > 0;
    for (const FaceHandle f : mesh.vf_range(v)) {
      if (on_boundary ? patch.contains(f) : !(patch.contains(f) && fixed_face(f))) continue;
      sum += mesh.calc_face_normal(f);
    }
    if (!(sum.norm() > 1e-12)) return std::nullopt;
    return sum / sum.norm();
  };
  // Visited edges: the hole boundary and the edges of fixed triangles.
  const auto visited = [&](HalfedgeHandle h) {
    const HalfedgeHandle o = mesh.opposite_halfedge_handle(h);
    const FaceHandle a = mesh.face_handle(h), b = mesh.face_handle(o);
    if (patch.contains(a) != patch.contains(b)) return true;  // hole boundary
    return (patch.contains(a) && fixed_face(a)) || (patch.contains(b) && fixed_face(b));
  };
  for (std::size_t round = 0; round < 4 * free_vertices.size() + 4 && !free_vertices.empty();
       ++round) {
    std::map<int, Vec3> updates;
    for (const int index : free_vertices) {
      const VertexHandle k(index);
      Vec3 sum(0, 0, 0);
      int count = 0;
      for (const HalfedgeHandle h : mesh.voh_range(k)) {
        // h = k->vi and next(h) = vi->vj: the edge (vi, vj) of this face is opposite k.
        if (mesh.is_boundary(h) || !patch.contains(mesh.face_handle(h))) continue;
        const HalfedgeHandle across = mesh.next_halfedge_handle(h);
        const VertexHandle vi = mesh.from_vertex_handle(across), vj = mesh.to_vertex_handle(across);
        // The face is (vi, vj, k) cyclically: the thesis' (P_i, P_j, P_k) with e_ij visited.
        if (!fixed.count(vi.idx()) || !fixed.count(vj.idx()) || !visited(across)) continue;
        const auto ni = vertex_normal(vi), nj = vertex_normal(vj);
        if (!ni || !nj) continue;
        Vec3 m = *ni + *nj;
        if (!(m.norm() > 1e-6)) continue;
        const Vec3 pi = mesh.point(vi), pj = mesh.point(vj), pk = mesh.point(k);
        Vec3 a = pj - pi;
        if (!(a.norm() > 0)) continue;
        a /= a.norm();
        m -= OpenMesh::dot(m, a) * a;
        if (!(m.norm() > 1e-9)) continue;
        m /= m.norm();
        const Vec3 r = pk - pi;
        const Vec3 along = OpenMesh::dot(r, a) * a;
        const double rho = (r - along).norm();
        if (!(rho > 1e-12)) continue;
        // (pj - pi) x (new - pi) is parallel to a x (m x a) = m: the face (i, j, k) gets normal m.
        sum += pi + along + rho * OpenMesh::cross(m, a);
        ++count;
      }
      if (count > 0) updates[index] = sum / count;
    }
    if (updates.empty()) break;
    for (const auto& [index, p] : updates) {
      mesh.set_point(VertexHandle(index), p);
      fixed.insert(index);
      free_vertices.erase(index);
      ++report.moved;
    }
    ++report.rounds;
  }
  return report;
}

int side_of_curve(const GuideSurface& guide, const Vec3& p) {
  const Point2 q = guide.frame.project(p);
  double best = std::numeric_limits<double>::infinity();
  int side = 0;
  for (std::size_t k = 0; k + 1 < guide.polyline.size(); ++k) {
    const Point2& a = guide.polyline[k];
    const Point2 ab = guide.polyline[k + 1] - a;
    const double length2 = ab.squaredNorm();
    const double t = length2 > 0 ? std::clamp((q - a).dot(ab) / length2, 0.0, 1.0) : 0.0;
    const double d = (a + t * ab - q).squaredNorm();
    if (d < best) {
      best = d;
      const double o = orient2d(a, a + ab, q);
      side = o > 0 ? 1 : (o < 0 ? -1 : 0);
    }
  }
  return side;
}

CurveFairingReport fair_beside_curve(Mesh& mesh, const SharpEdgeState& state) {
  CurveFairingReport report;
  const FaceSet patch(state.patch);
  const auto fixed = [&](VertexHandle v) {
    return state.boundary.count(v.idx()) > 0 || state.on_guide.count(v.idx()) > 0 ||
           state.moved.count(v.idx()) > 0;
  };
  // Sides from the positions before any vertex moves: the first side's fairing must not
  // change which side the second side's faces are on.
  std::map<int, int> face_side;
  std::array<std::vector<VertexHandle>, 2> free_vertices;
  std::set<int> seen;
  for (const FaceHandle f : state.patch) {
    if (mesh.status(f).deleted()) continue;
    Vec3 centroid(0, 0, 0);
    for (const VertexHandle v : mesh.fv_range(f)) {
      centroid += mesh.point(v) / 3.0;
      if (fixed(v) || !seen.insert(v.idx()).second) continue;
      const int side = side_of_curve(state.guide, mesh.point(v));
      free_vertices[side >= 0 ? 0 : 1].push_back(v);
    }
    face_side[f.idx()] = side_of_curve(state.guide, centroid);
  }
  std::map<int, Vec3> before;
  for (const auto& side : free_vertices)
    for (const VertexHandle v : side) before[v.idx()] = mesh.point(v);
  for (int s = 0; s < 2; ++s) {
    if (free_vertices[s].empty()) continue;
    const int side = s == 0 ? 1 : -1;
    FairingOptions options;
    // The surroundings of a crease are two surfaces, not one sphere or quadric.
    options.base_fit_rings = 0;
    options.ignore_face = [&](FaceHandle f) {
      if (!patch.contains(f)) return false;
      const auto it = face_side.find(f.idx());
      return it != face_side.end() && it->second != 0 && it->second != side;
    };
    const FairingReport r = fair_vertices(mesh, free_vertices[s], options);
    if (!r.ok) {
      for (const auto& [index, p] : before) mesh.set_point(VertexHandle(index), p);
      report.failure = r.failure;
      return report;
    }
    report.moved += r.free_vertices;
  }
  report.ok = true;
  return report;
}

const char* to_string(PushFinish finish) {
  switch (finish) {
    case PushFinish::Fair:
      return "fair";
    case PushFinish::Smooth:
      return "smooth";
    case PushFinish::None:
      return "none";
  }
  return "?";
}

bool parse_push_finish(std::string_view text, PushFinish& finish) {
  for (const PushFinish f : {PushFinish::Fair, PushFinish::Smooth, PushFinish::None})
    if (text == to_string(f)) {
      finish = f;
      return true;
    }
  return false;
}

PushFinishReport finish_push(Mesh& mesh, const SharpEdgeState& state, PushFinish finish,
                             bool check_intersections) {
  PushFinishReport report;
  if (finish == PushFinish::None) return report;
  std::vector<FaceHandle> patch;
  std::vector<std::pair<VertexHandle, Vec3>> before;
  for (const FaceHandle f : state.patch) {
    if (mesh.status(f).deleted()) continue;
    patch.push_back(f);
    for (const VertexHandle v : mesh.fv_range(f)) before.emplace_back(v, mesh.point(v));
  }
  const char* what = finish == PushFinish::Smooth ? "smoothing" : "fairing";
  if (finish == PushFinish::Smooth) {
    report.smooth = smooth_by_normal_propagation(mesh, state);
  } else {
    report.fairing = fair_beside_curve(mesh, state);
    if (!report.fairing.ok) report.undone = "fairing failed: " + report.fairing.failure;
  }
  if (report.undone.empty() && check_intersections &&
      !find_face_intersections(mesh, patch, 1, max_edge_length(mesh)).empty())
    report.undone = std::string(what) + " would make the patch intersect the mesh";
  if (!report.undone.empty()) {
    for (const auto& [v, old] : before) mesh.set_point(v, old);
    report.smooth = {};
    report.fairing.moved = 0;
  }
  return report;
}

}  // namespace touchmend::geometry
