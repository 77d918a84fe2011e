#include "server/geometry/ring_joining.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "server/geometry/intersection.h"
#include "server/geometry/pinch_closing.h"
#include "server/geometry/projection.h"

namespace touchmend::geometry {

namespace {

//! Quads tried, shortest first, before the join is given up.
constexpr std::size_t kJoinCandidates = 8;
//! The joining triangles fold against each other by at most 60°, and each is no needle.
constexpr double kJoinFoldCos = 0.5;
constexpr double kJoinMinAngleSine = 0.02;  // about 1.1°
//! A loop's rim faces "face its Newell normal's way" when the mean cosine passes this.
constexpr double kRimFacingCos = 0.25;
//! Two levels joined by a straight wall have borders of the same area (up to the cut's ragged
//! edge); which one is outer, the rims' facing decides.
constexpr double kSameAreaSlack = 1.05;
//! At most this share of the outer loop's vertices may dip towards the inner level.
constexpr double kMaxDippingShare = 0.25;
//! ... and its Newell normal, tilted by the dips, stays within 25° of the inner plane's.
constexpr double kDippedNormalCos = 0.9;

Vec3 unit_normal(const Vec3& a, const Vec3& b, const Vec3& c) {
  return OpenMesh::cross(b - a, c - a).normalize_cond();
}

//! The mean over \p hole's rim faces of their unit normals' cosine with \p direction.
double rim_faces_along(const Mesh& mesh, const Hole& hole, const Vec3& direction) {
  double sum = 0;
  std::size_t faces = 0;
  for (const HalfedgeHandle h : hole.halfedges) {
    const FaceHandle f = mesh.face_handle(mesh.opposite_halfedge_handle(h));
    if (!f.is_valid()) continue;
    sum += OpenMesh::dot(mesh.calc_face_normal(f), direction);
    ++faces;
  }
  return faces > 0 ? sum / static_cast<double>(faces) : 0;
}

double distance_to_outline(std::span<const Point2> outline, const Point2& p) {
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < outline.size(); ++i) {
    const Point2& a = outline[i];
    const Point2& b = outline[(i + 1) % outline.size()];
    const Point2 ab = b - a;
    const double length2 = ab.squaredNorm();
    const double s = length2 > 0 ? std::clamp((p - a).dot(ab) / length2, 0.0, 1.0) : 0.0;
    best = std::min(best, (p - (a + s * ab)).norm());
  }
  return best;
}

//! Where the inner loop lies against the outer loop's plane.
enum class RingLevel { OnThePlane, TwoLevels, Neither };

struct RingLayout {
  RingLevel level = RingLevel::Neither;
  Vec3 origin = Vec3(0, 0, 0);  //!< a point of the outer loop's plane
  Vec3 normal = Vec3(0, 0, 1);  //!< the outer loop's plane's normal, the way its patch faces
};

//! The outer loop's plane is its Newell normal through its centroid when the loop is
//! near-planar. On two levels it may also dip off that plane towards the inner level at a few
//! vertices (a wall cut only partly: the mouth's border runs down the wall's remains and back);
//! the plane is then parallel to the (planar) inner loop, through the outer loop's vertices'
//! median height.
RingLayout ring_layout(const Mesh& mesh, const Hole& outer, const Hole& inner,
                       const RingBorderOptions& options) {
  RingLayout out;
  if (inner.loop.empty() || outer.loop.empty()) return out;
  const double radius = std::sqrt(std::max(outer.area, 0.0) / std::numbers::pi);
  const double off_plane = options.max_off_plane * radius;
  const double max_offset = options.max_level_offset * radius;
  out.normal = outer.newell_normal;
  if (outer.planarity > off_plane) {
    // Dipping: the inner loop's plane (the Newell normal of a loop that dips is tilted).
    if (inner.planarity > off_plane ||
        !(OpenMesh::dot(outer.newell_normal, inner.newell_normal) < -kDippedNormalCos))
      return out;
    out.normal = -inner.newell_normal;
  }
  const auto height = [&](VertexHandle v) {
    return OpenMesh::dot(mesh.point(v) - outer.centroid, out.normal);
  };
  // A comb's gaps (narrow notches, which the fill closes with their ears first) do not count:
  // the inner loop's level is that of its teeth.
  double lowest = std::numeric_limits<double>::infinity(), highest = -lowest;
  for (std::size_t i = 0; i < inner.loop.size(); ++i) {
    if (is_narrow_notch(mesh, inner, i)) continue;
    lowest = std::min(lowest, height(inner.loop[i]));
    highest = std::max(highest, height(inner.loop[i]));
  }
  if (!(lowest <= highest)) return out;
  // On a parallel plane within reach (the wall between the levels went with the ring).
  const auto parallel = [&](double level) {
    const double offset = 0.5 * (lowest + highest) - level;
    return highest - lowest <= off_plane && std::abs(offset) > off_plane &&
           std::abs(offset) <= max_offset;
  };
  if (outer.planarity <= off_plane) {
    out.origin = outer.centroid;
    if (std::max(std::abs(lowest), std::abs(highest)) <= off_plane)
      out.level = RingLevel::OnThePlane;
    else if (parallel(0.0))
      out.level = RingLevel::TwoLevels;
    return out;
  }
  std::vector<double> heights;
  heights.reserve(outer.loop.size());
  for (const VertexHandle v : outer.loop) heights.push_back(height(v));
  std::vector<double> sorted = heights;
  const auto middle = sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2);
  std::nth_element(sorted.begin(), middle, sorted.end());
  const double level = *middle;
  if (!parallel(level)) return out;
  const double offset = 0.5 * (lowest + highest) - level;
  std::size_t dipping = 0;
  for (const double h : heights) {
    const double off = h - level;
    if (std::abs(off) <= off_plane) continue;
    // Down the wall towards the inner level, not past it.
    if (off * offset < 0 || std::abs(off) > std::abs(offset) + off_plane) return out;
    ++dipping;
  }
  if (static_cast<double>(dipping) > kMaxDippingShare * static_cast<double>(heights.size()))
    return out;
  out.origin = outer.centroid + level * out.normal;
  out.level = RingLevel::TwoLevels;
  return out;
}

}  // namespace

bool borders_one_ring(const Mesh& mesh, const Hole& outer, const Hole& inner,
                      const RingBorderOptions& options) {
  if (outer.loop.size() < 3 || inner.loop.size() < 3 || !outer.pinched_at.empty() ||
      !inner.pinched_at.empty() || !outer.unfillable_reason.empty() ||
      !inner.unfillable_reason.empty() || !(outer.area > 0) || !(inner.area > 0) ||
      inner.area > kSameAreaSlack * outer.area)
    return false;
  // Opposite ways round: the two borders of one region.
  if (!(OpenMesh::dot(outer.newell_normal, inner.newell_normal) < -0.5)) return false;
  // The region lies inside the outer loop and outside the inner one. A patch of a loop faces
  // its Newell normal's way; the surface beside a loop whose region lies outside it (the border
  // of an open sheet, an island's border) faces the other way where it lies in the plane. Walls
  // standing on the plane (a counterbore's) face across it and decide nothing.
  if (rim_faces_along(mesh, outer, outer.newell_normal) < -kRimFacingCos ||
      rim_faces_along(mesh, inner, inner.newell_normal) > kRimFacingCos)
    return false;
  const double radius = std::sqrt(outer.area / std::numbers::pi);
  const double off_plane = options.max_off_plane * radius;
  const RingLayout layout = ring_layout(mesh, outer, inner, options);
  if (layout.level == RingLevel::Neither) return false;
  const ReferenceFrame plane = ReferenceFrame::from_normal(layout.normal, layout.origin);
  std::vector<Point2> outline;
  outline.reserve(outer.loop.size());
  for (const VertexHandle v : outer.loop) outline.push_back(plane.project(mesh.point(v)));
  for (const VertexHandle v : inner.loop) {
    const Point2 p = plane.project(mesh.point(v));
    // A straight wall's lower border projects onto the outer loop itself.
    if (!point_in_polygon(outline, p) &&
        !(layout.level == RingLevel::TwoLevels && distance_to_outline(outline, p) <= off_plane))
      return false;
  }
  return true;
}

std::vector<std::pair<std::size_t, std::size_t>> find_ring_borders(
    const Mesh& mesh, std::span<const Hole* const> holes, const RingBorderOptions& options) {
  // Each hole's box, to skip the pairs whose boxes do not nest.
  std::vector<std::pair<Vec3, Vec3>> boxes;
  for (const Hole* h : holes) {
    Vec3 lo(1e300, 1e300, 1e300), hi(-1e300, -1e300, -1e300);
    for (const VertexHandle v : h->loop) {
      lo.minimize(mesh.point(v));
      hi.maximize(mesh.point(v));
    }
    boxes.emplace_back(lo, hi);
  }
  std::vector<std::vector<std::size_t>> inside_of(holes.size());
  std::vector<std::size_t> enclosing(holes.size(), 0);
  for (std::size_t o = 0; o < holes.size(); ++o) {
    // A tenth of the box's size on every side, and the farthest second level along the outer
    // loop's normal.
    Vec3 slack;
    const double size = (boxes[o].second - boxes[o].first).norm();
    const double level = options.max_level_offset * std::sqrt(holes[o]->area / std::numbers::pi);
    for (int k = 0; k < 3; ++k)
      slack[k] = 0.1 * size + std::abs(holes[o]->newell_normal[k]) * level;
    for (std::size_t i = 0; i < holes.size(); ++i) {
      if (i == o) continue;
      bool nested = true;
      for (int k = 0; k < 3; ++k)
        nested = nested && boxes[i].first[k] >= boxes[o].first[k] - slack[k] &&
                 boxes[i].second[k] <= boxes[o].second[k] + slack[k];
      if (nested && borders_one_ring(mesh, *holes[o], *holes[i], options)) {
        inside_of[o].push_back(i);
        ++enclosing[i];
      }
    }
  }
  std::vector<std::pair<std::size_t, std::size_t>> out;
  for (std::size_t o = 0; o < holes.size(); ++o)
    if (inside_of[o].size() == 1 && enclosing[inside_of[o].front()] == 1 && enclosing[o] == 0)
      out.emplace_back(o, inside_of[o].front());
  return out;
}

RingJoin join_ring_borders(Mesh& mesh, const Hole& outer, const Hole& inner,
                           const SearchReach& reach) {
  RingJoin out;
  const std::size_t no = outer.loop.size(), ni = inner.loop.size();
  struct Quad {
    double cost;
    std::size_t i, j;  // outer halfedge a -> b, inner halfedge t -> t'
  };
  std::vector<Quad> quads;
  quads.reserve(no * ni);
  for (std::size_t i = 0; i < no; ++i)
    for (std::size_t j = 0; j < ni; ++j) {
      const Vec3& a = mesh.point(outer.loop[i]);
      const Vec3& b = mesh.point(outer.loop[(i + 1) % no]);
      const Vec3& t = mesh.point(inner.loop[j]);
      const Vec3& t2 = mesh.point(inner.loop[(j + 1) % ni]);
      quads.push_back({(b - t).norm() + (t2 - a).norm(), i, j});
    }
  // On one plane the joining triangles lie in the ring and face as a patch of the outer loop
  // would; across two levels they are a piece of the wall between them, standing on the outer
  // loop's plane (facing across it, but not back against it).
  const bool two_levels = ring_layout(mesh, outer, inner, {}).level == RingLevel::TwoLevels;
  const double min_facing_cos = two_levels ? -kJoinFoldCos : kJoinFoldCos;
  const std::size_t tried = std::min(kJoinCandidates, quads.size());
  std::partial_sort(quads.begin(), quads.begin() + static_cast<std::ptrdiff_t>(tried), quads.end(),
                    [](const Quad& x, const Quad& y) { return x.cost < y.cost; });
  for (std::size_t k = 0; k < tried; ++k) {
    const VertexHandle a = outer.loop[quads[k].i], b = outer.loop[(quads[k].i + 1) % no];
    const VertexHandle t = inner.loop[quads[k].j], t2 = inner.loop[(quads[k].j + 1) % ni];
    const Vec3 pa = mesh.point(a), pb = mesh.point(b), pt = mesh.point(t), pt2 = mesh.point(t2);
    // Facing as a patch of the outer loop would (its boundary halfedges' way round), not
    // folded, no needles.
    const Vec3 n1 = unit_normal(pa, pb, pt), n2 = unit_normal(pt, pt2, pa);
    if (!(OpenMesh::dot(n1, outer.newell_normal) > min_facing_cos) ||
        !(OpenMesh::dot(n2, outer.newell_normal) > min_facing_cos) ||
        !(OpenMesh::dot(n1, n2) > kJoinFoldCos) ||
        !(min_angle_sine(pa, pb, pt) > kJoinMinAngleSine) ||
        !(min_angle_sine(pt, pt2, pa) > kJoinMinAngleSine))
      continue;
    if (mesh.find_halfedge(a, t).is_valid() || mesh.find_halfedge(b, t).is_valid() ||
        mesh.find_halfedge(a, t2).is_valid())
      continue;
    const FaceHandle f1 = mesh.add_face(a, b, t);
    if (!f1.is_valid()) continue;
    const FaceHandle f2 = mesh.add_face(t, t2, a);
    if (!f2.is_valid()) {
      mesh.delete_face(f1, false);
      continue;
    }
    const std::vector<FaceHandle> faces{f1, f2};
    Hole joined;
    const HalfedgeHandle start = mesh.find_halfedge(a, t2);
    const bool linked = start.is_valid() && mesh.is_boundary(start) &&
                        trace_hole_loop(mesh, start, no + ni, joined) &&
                        joined.loop.size() == no + ni;
    if (!linked || !find_intersections_with_rest(mesh, faces, 1, reach).empty()) {
      mesh.delete_face(f2, false);
      mesh.delete_face(f1, false);
      continue;
    }
    joined.id = outer.id;
    compute_hole_properties(mesh, joined, /*compute_projectability=*/true);
    out.faces = faces;
    out.hole = std::move(joined);
    return out;
  }
  out.failure = "no two triangles join the ring's borders without folding or meeting the mesh";
  return out;
}

}  // namespace touchmend::geometry
