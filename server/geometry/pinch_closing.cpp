#include "server/geometry/pinch_closing.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>

#include <fmt/format.h>

#include "server/geometry/intersection.h"
#include "server/geometry/patch_quality.h"

namespace touchmend::geometry {

namespace {

//! A corner's triangle that folds against one of its two rim neighbours by more than 60° is
//! taken only after those that continue the surface, whatever their angles: on couplingdown's
//! combs (a cut through a cylinder wall of long strip triangles, leaving a chain of lone teeth
//! that touch at their corners) the wall triangles between the teeth have 3° corners and the
//! chords across the ring under them 7°, and the largest smallest angle alone spanned the ring.
constexpr double kCornerFoldCos = 0.5;

//! close_notches: a rim corner narrower than DESIGN's 15° smallest angle...
constexpr double kNotchMaxCornerDeg = 15.0;
//! ...whose ear continues both rim faces within 30° (cosine).
const double kNotchMaxFoldCos = std::cos(30.0 * std::numbers::pi / 180);

Vec3 unit_face_normal(const Mesh& mesh, VertexHandle a, VertexHandle b, VertexHandle c) {
  Vec3 n = OpenMesh::cross(mesh.point(b) - mesh.point(a), mesh.point(c) - mesh.point(a));
  return n.normalize_cond();
}

//! Whether the triangle \p corner = (p, v, a) folds against the face across either rim
//! halfedge of \p rim (p -> v and v -> a) by more than the angle whose cosine is \p min_cos.
bool folds_against_rim(const Mesh& mesh, const std::array<VertexHandle, 3>& corner,
                       const std::array<HalfedgeHandle, 2>& rim, double min_cos) {
  const Vec3 normal = unit_face_normal(mesh, corner[0], corner[1], corner[2]);
  for (const HalfedgeHandle h : rim) {
    const FaceHandle neighbour = mesh.face_handle(mesh.opposite_halfedge_handle(h));
    if (!neighbour.is_valid() ||
        !(OpenMesh::dot(normal, mesh.calc_face_normal(neighbour)) > min_cos))
      return true;
  }
  return false;
}

//! Adds the face (p, v, a) across the rim's corner p -> v -> a, which takes those two boundary
//! halfedges; returns the loop's new boundary halfedge p -> a, or an invalid handle (and the
//! mesh as it was) when the face cannot be added, meets another face or does not link in.
HalfedgeHandle add_corner_face(Mesh& mesh, VertexHandle p, VertexHandle v, VertexHandle a,
                               const SearchReach& reach) {
  const FaceHandle f = mesh.add_face(p, v, a);
  if (!f.is_valid()) return HalfedgeHandle();
  const FaceHandle one[] = {f};
  const HalfedgeHandle joined = mesh.find_halfedge(p, a);
  if (!find_intersections_with_rest(mesh, one, 1, reach).empty() || !joined.is_valid() ||
      !mesh.is_boundary(joined)) {
    mesh.delete_face(f, false);
    return HalfedgeHandle();
  }
  return joined;
}

//! The loop as the mesh now links it, from \p halfedges' first around into \p disk: false
//! unless it is \p halfedges (a walk that takes another way at a vertex where more fans meet
//! is not filled).
bool linked_as_one_loop(const Mesh& mesh, const std::vector<HalfedgeHandle>& halfedges,
                        Hole& disk) {
  return trace_hole_loop(mesh, halfedges.front(), halfedges.size(), disk) &&
         disk.halfedges == halfedges;
}

//! The disk keeps the hole's id and gets its own properties.
void finish_disk(const Mesh& mesh, const Hole& hole, Hole& disk) {
  disk.id = hole.id;
  compute_hole_properties(mesh, disk, /*compute_projectability=*/true);
}

}  // namespace

PinchClosure close_pinches(Mesh& mesh, const Hole& hole, const SearchReach& reach) {
  PinchClosure out;
  std::vector<VertexHandle> loop = hole.loop;
  std::vector<HalfedgeHandle> halfedges = hole.halfedges;
  for (const VertexHandle v : hole.pinched_at) {
    for (;;) {
      std::vector<std::size_t> corners;
      for (std::size_t i = 0; i < loop.size(); ++i)
        if (loop[i] == v) corners.push_back(i);
      if (corners.size() < 2) break;
      struct Candidate {
        bool folds;  //!< against one of its two rim neighbours by more than 60°
        double sine;
        std::size_t corner;
      };
      std::vector<Candidate> candidates;
      const std::size_t n = loop.size();
      for (const std::size_t i : corners) {
        const VertexHandle p = loop[(i + n - 1) % n], a = loop[(i + 1) % n];
        if (p == a || p == v || a == v) continue;
        if (mesh.find_halfedge(p, a).is_valid() || mesh.find_halfedge(a, p).is_valid()) continue;
        const double sine = min_angle_sine(mesh.point(p), mesh.point(v), mesh.point(a));
        if (!(sine > std::sin(kDegenerateAngleDeg * std::numbers::pi / 180))) continue;
        const bool folds = folds_against_rim(
            mesh, {p, v, a}, {halfedges[(i + n - 1) % n], halfedges[i]}, kCornerFoldCos);
        candidates.push_back({folds, sine, i});
      }
      std::stable_sort(candidates.begin(), candidates.end(),
                       [](const Candidate& x, const Candidate& y) {
                         return x.folds != y.folds ? !x.folds : x.sine > y.sine;
                       });
      bool closed = false;
      for (const Candidate& c : candidates) {
        const std::size_t i = c.corner;
        const VertexHandle p = loop[(i + n - 1) % n], a = loop[(i + 1) % n];
        // The face across the corner takes the two boundary halfedges p -> v -> a; its third
        // edge's other half, p -> a, is the loop's new boundary halfedge.
        const HalfedgeHandle joined = add_corner_face(mesh, p, v, a, reach);
        if (!joined.is_valid()) continue;
        out.faces.push_back(mesh.face_handle(mesh.opposite_halfedge_handle(joined)));
        out.corners.push_back({p, v, a});
        // The loop without this corner: p -> a replaces p -> v -> a.
        const std::size_t previous = (i + n - 1) % n;
        halfedges[previous] = joined;
        loop.erase(loop.begin() + static_cast<std::ptrdiff_t>(i));
        halfedges.erase(halfedges.begin() + static_cast<std::ptrdiff_t>(i));
        closed = true;
        break;
      }
      if (!closed) {
        out.failure = fmt::format(
            "no triangle closes its corners at vertex {} (each would repeat an edge, be "
            "degenerate, not link into the mesh or meet another face)",
            v.idx());
        return out;
      }
    }
  }
  if (!linked_as_one_loop(mesh, halfedges, out.hole))
    out.failure = "the boundary left after closing the pinch is not one loop";
  else
    finish_disk(mesh, hole, out.hole);
  return out;
}

namespace {

//! The cosine of the rim's corner p -> v -> a when it is narrower than a notch's limit.
std::optional<double> narrow_corner_cos(const Mesh& mesh, VertexHandle p, VertexHandle v,
                                        VertexHandle a) {
  const Vec3 to_p = (mesh.point(p) - mesh.point(v)).normalize_cond();
  const Vec3 to_a = (mesh.point(a) - mesh.point(v)).normalize_cond();
  const double corner_cos = OpenMesh::dot(to_p, to_a);
  if (!(corner_cos > std::cos(kNotchMaxCornerDeg * std::numbers::pi / 180))) return std::nullopt;
  return corner_cos;
}

}  // namespace

bool is_narrow_notch(const Mesh& mesh, const Hole& hole, std::size_t i) {
  const std::size_t n = hole.loop.size();
  if (n < 4 || hole.halfedges.size() != n) return false;
  const std::size_t previous = (i + n - 1) % n;
  const VertexHandle p = hole.loop[previous], v = hole.loop[i], a = hole.loop[(i + 1) % n];
  return narrow_corner_cos(mesh, p, v, a) &&
         !folds_against_rim(mesh, {p, v, a}, {hole.halfedges[previous], hole.halfedges[i]},
                            kNotchMaxFoldCos);
}

PinchClosure close_notches(Mesh& mesh, const Hole& hole, const SearchReach& reach) {
  PinchClosure out;
  std::vector<VertexHandle> loop = hole.loop;
  std::vector<HalfedgeHandle> halfedges = hole.halfedges;
  // One ear at a time, the scan begun again after each: closing one changes the corners of its
  // two neighbours. An ear refused for meeting the mesh or not linking in is not tried again
  // (each such test is a search of the faces near it).
  std::vector<std::array<VertexHandle, 3>> refused;
  for (bool closed = true; closed && loop.size() > 3;) {
    closed = false;
    const std::size_t n = loop.size();
    for (std::size_t i = 0; i < n && !closed; ++i) {
      const std::size_t previous = (i + n - 1) % n;
      const VertexHandle p = loop[previous], v = loop[i], a = loop[(i + 1) % n];
      if (p == a || p == v || a == v) continue;
      const std::optional<double> corner_cos = narrow_corner_cos(mesh, p, v, a);
      if (!corner_cos) continue;
      if (mesh.find_halfedge(p, a).is_valid() || mesh.find_halfedge(a, p).is_valid()) continue;
      // The corner is the ear's smallest angle (1e-9: the corner itself, rounded).
      const double corner_sine = std::sqrt(std::max(0.0, 1 - *corner_cos * *corner_cos));
      const double sine = min_angle_sine(mesh.point(p), mesh.point(v), mesh.point(a));
      if (!(sine > std::sin(kDegenerateAngleDeg * std::numbers::pi / 180)) ||
          sine < corner_sine - 1e-9)
        continue;
      if (folds_against_rim(mesh, {p, v, a}, {halfedges[previous], halfedges[i]}, kNotchMaxFoldCos))
        continue;
      const std::array<VertexHandle, 3> ear{p, v, a};
      if (std::find(refused.begin(), refused.end(), ear) != refused.end()) continue;
      const HalfedgeHandle joined = add_corner_face(mesh, p, v, a, reach);
      if (!joined.is_valid()) {
        refused.push_back(ear);
        continue;
      }
      out.faces.push_back(mesh.face_handle(mesh.opposite_halfedge_handle(joined)));
      halfedges[previous] = joined;
      loop.erase(loop.begin() + static_cast<std::ptrdiff_t>(i));
      halfedges.erase(halfedges.begin() + static_cast<std::ptrdiff_t>(i));
      closed = true;
    }
  }
  if (out.faces.empty()) {
    out.hole = hole;
    return out;
  }
  if (!linked_as_one_loop(mesh, halfedges, out.hole))
    out.failure = "the boundary left after closing its narrow corners is not one loop";
  else
    finish_disk(mesh, hole, out.hole);
  return out;
}

std::size_t flip_pinch_closing_edges(Mesh& mesh, const PinchClosure& closure,
                                     const SearchReach& reach) {
  std::size_t flips = 0;
  const auto sine = [&](VertexHandle a, VertexHandle b, VertexHandle c) {
    return min_angle_sine(mesh.point(a), mesh.point(b), mesh.point(c));
  };
  for (const auto& [p, v, a] : closure.corners) {
    const HalfedgeHandle h = mesh.find_halfedge(p, a);
    if (!h.is_valid() || mesh.is_boundary(h)) continue;
    const FaceHandle g = mesh.face_handle(h);
    if (std::find(closure.faces.begin(), closure.faces.end(), g) != closure.faces.end()) continue;
    const VertexHandle x = mesh.to_vertex_handle(mesh.next_halfedge_handle(h));
    const EdgeHandle e = mesh.edge_handle(h);
    if (x == v || !mesh.is_flip_ok(e)) continue;
    if (!(std::min(sine(v, a, x), sine(x, p, v)) > std::min(sine(p, v, a), sine(p, a, x))))
      continue;
    const Vec3 before =
        (unit_face_normal(mesh, p, v, a) + unit_face_normal(mesh, p, a, x)).normalize_cond();
    if (!(OpenMesh::dot(unit_face_normal(mesh, v, a, x), before) > 0.5) ||
        !(OpenMesh::dot(unit_face_normal(mesh, x, p, v), before) > 0.5))
      continue;
    mesh.flip(e);
    const HalfedgeHandle flipped = mesh.halfedge_handle(e, 0);
    const FaceHandle pair[] = {mesh.face_handle(flipped),
                               mesh.face_handle(mesh.opposite_halfedge_handle(flipped))};
    if (!find_face_intersections(mesh, pair, 1, reach).empty()) {
      mesh.flip(e);  // back to p-a
      continue;
    }
    ++flips;
  }
  return flips;
}

}  // namespace touchmend::geometry
