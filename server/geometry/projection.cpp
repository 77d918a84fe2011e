#include "server/geometry/projection.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>

#include <Eigen/Eigenvalues>

namespace touchmend::geometry {

ReferenceFrame ReferenceFrame::from_normal(const Vec3& normal, const Vec3& origin) {
  ReferenceFrame f;
  f.origin = origin;
  Vec3 n = normal;
  const double len = n.norm();
  n = len > 0 ? n / len : Vec3(0, 0, 1);
  // Branch-free orthonormal basis (Duff et al. 2017, "Building an Orthonormal Basis, Revisited").
  const double sign = std::copysign(1.0, n[2]);
  const double a = -1.0 / (sign + n[2]);
  const double b = n[0] * n[1] * a;
  f.e1 = Vec3(1.0 + sign * n[0] * n[0] * a, sign * b, -sign * n[0]);
  f.e2 = Vec3(b, sign + n[1] * n[1] * a, -n[1]);
  // Ensure a right-handed frame (e1 x e2 = n), so counter-clockwise stays counter-clockwise.
  if (OpenMesh::dot(OpenMesh::cross(f.e1, f.e2), n) < 0) std::swap(f.e1, f.e2);
  f.normal = n;
  return f;
}

namespace {

//! Whether edge (a, b) crosses the ray from \p p towards +x (half-open in y, so a vertex on the
//! ray counts once): the even-odd test's step.
bool crosses_ray(const Point2& a, const Point2& b, const Point2& p) {
  return (a.y() > p.y()) != (b.y() > p.y()) &&
         p.x() < (b.x() - a.x()) * (p.y() - a.y()) / (b.y() - a.y()) + a.x();
}

}  // namespace

bool point_in_polygon(std::span<const Point2> polygon, const Point2& p) {
  bool inside = false;
  const std::size_t n = polygon.size();
  for (std::size_t i = 0, j = n - 1; i < n; j = i++)
    if (crosses_ray(polygon[i], polygon[j], p)) inside = !inside;
  return inside;
}

double signed_area(std::span<const Point2> polygon) {
  double a = 0;
  const std::size_t n = polygon.size();
  for (std::size_t i = 0; i < n; ++i) {
    const Point2& p = polygon[i];
    const Point2& q = polygon[(i + 1) % n];
    a += p.x() * q.y() - q.x() * p.y();
  }
  return 0.5 * a;
}

bool segments_cross(const Point2& a, const Point2& b, const Point2& c, const Point2& d,
                    bool count_touching) {
  const double d1 = orient2d(a, b, c), d2 = orient2d(a, b, d);
  const double d3 = orient2d(c, d, a), d4 = orient2d(c, d, b);
  if (((d1 > 0 && d2 < 0) || (d1 < 0 && d2 > 0)) && ((d3 > 0 && d4 < 0) || (d3 < 0 && d4 > 0)))
    return true;
  if (!count_touching) return false;
  auto on_segment = [](const Point2& p, const Point2& q, const Point2& r) {
    return std::min(p.x(), q.x()) <= r.x() && r.x() <= std::max(p.x(), q.x()) &&
           std::min(p.y(), q.y()) <= r.y() && r.y() <= std::max(p.y(), q.y());
  };
  return (d1 == 0 && on_segment(a, b, c)) || (d2 == 0 && on_segment(a, b, d)) ||
         (d3 == 0 && on_segment(c, d, a)) || (d4 == 0 && on_segment(c, d, b));
}

std::size_t count_self_intersections(std::span<const Point2> polygon) {
  const std::size_t n = polygon.size();
  if (n < 4) return 0;
  std::size_t count = 0;
  // Bounding boxes per edge for a cheap reject.
  std::vector<Eigen::AlignedBox2d> boxes(n);
  for (std::size_t i = 0; i < n; ++i) {
    boxes[i].extend(polygon[i]);
    boxes[i].extend(polygon[(i + 1) % n]);
  }
  // Sweep over x: only edges whose x-ranges overlap are compared, so a hole of hundreds of
  // boundary vertices costs about n log n instead of n^2 pair tests. (A coincidence of two
  // loop vertices makes both edges' boxes contain the point, so it is met by the sweep too.)
  std::vector<std::size_t> order(n);
  for (std::size_t i = 0; i < n; ++i) order[i] = i;
  std::sort(order.begin(), order.end(),
            [&](std::size_t a, std::size_t b) { return boxes[a].min().x() < boxes[b].min().x(); });
  for (std::size_t a = 0; a < n; ++a) {
    const std::size_t ea = order[a];
    for (std::size_t b = a + 1; b < n && boxes[order[b]].min().x() <= boxes[ea].max().x(); ++b) {
      const std::size_t i = std::min(ea, order[b]);
      const std::size_t j = std::max(ea, order[b]);
      const bool adjacent = j == i + 1 || (i == 0 && j == n - 1);
      if (!adjacent && polygon[i] == polygon[j]) {
        ++count;  // two distinct loop vertices at the same 2D point
        continue;
      }
      if (adjacent || !boxes[i].intersects(boxes[j])) continue;
      if (segments_cross(polygon[i], polygon[(i + 1) % n], polygon[j], polygon[(j + 1) % n], true))
        ++count;
    }
  }
  // Adjacent edges folding back onto each other (a spike) also make the polygon non-simple.
  for (std::size_t i = 0; i < n; ++i) {
    const Point2& a = polygon[(i + n - 1) % n];
    const Point2& b = polygon[i];
    const Point2& c = polygon[(i + 1) % n];
    if (orient2d(a, b, c) == 0 && (a - b).dot(c - b) > 0) ++count;
  }
  return count;
}

namespace {

double distance_to_segment(const Point2& p, const Point2& a, const Point2& b) {
  const Point2 ab = b - a;
  const double len2 = ab.squaredNorm();
  const double t = len2 > 0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return (a + t * ab - p).norm();
}

//! point_in_polygon for many points against one polygon: its edges filed in horizontal slabs,
//! so a point is tested against the edges whose y-range meets its slab instead of all n (the
//! fold-over guard asks for every outside point, which made each projectability test O(n^2)).
//! The same crossing test on the same edges as point_in_polygon, so the same answers.
class SlabbedPolygon {
 public:
  explicit SlabbedPolygon(std::span<const Point2> polygon) : polygon_(polygon) {
    const std::size_t n = polygon.size();
    if (n == 0) return;
    y0_ = y1_ = polygon[0].y();
    for (const Point2& p : polygon) {
      y0_ = std::min(y0_, p.y());
      y1_ = std::max(y1_, p.y());
    }
    if (!(y1_ > y0_)) return;  // flat or NaN: no edge can cross a horizontal line
    slabs_ = std::max<std::size_t>(1, n / 2);
    scale_ = static_cast<double>(slabs_) / (y1_ - y0_);
    start_.assign(slabs_ + 1, 0);
    const auto for_each_filing = [&](auto&& file) {
      for (std::size_t i = 0, j = n - 1; i < n; j = i++) {
        const auto [lo, hi] = std::minmax(polygon[i].y(), polygon[j].y());
        for (std::size_t s = slab(lo); s <= slab(hi); ++s) file(s, static_cast<std::uint32_t>(i));
      }
    };
    for_each_filing([&](std::size_t s, std::uint32_t) { ++start_[s + 1]; });
    for (std::size_t s = 0; s < slabs_; ++s) start_[s + 1] += start_[s];
    edges_.resize(start_[slabs_]);
    std::vector<std::uint32_t> next(start_.begin(), start_.end() - 1);
    for_each_filing([&](std::size_t s, std::uint32_t i) { edges_[next[s]++] = i; });
  }

  //! Whether some edge lies within \p tolerance of \p p (distance_to_segment <= tolerance):
  //! only the edges of the slabs within tolerance of p.y can.
  bool near_edge(const Point2& p, double tolerance) const {
    const std::size_t n = polygon_.size();
    if (slabs_ == 0) {  // no slabs: every edge
      for (std::size_t i = 0, j = n - 1; i < n; j = i++)
        if (distance_to_segment(p, polygon_[i], polygon_[j]) <= tolerance) return true;
      return false;
    }
    if (p.y() + tolerance < y0_ || p.y() - tolerance > y1_) return false;
    for (std::size_t s = slab(p.y() - tolerance); s <= slab(p.y() + tolerance); ++s)
      for (std::uint32_t e = start_[s]; e < start_[s + 1]; ++e) {
        const std::size_t i = edges_[e], j = i == 0 ? n - 1 : i - 1;
        if (distance_to_segment(p, polygon_[i], polygon_[j]) <= tolerance) return true;
      }
    return false;
  }

  bool contains(const Point2& p) const {
    if (slabs_ == 0 || !(p.y() >= y0_ && p.y() < y1_)) return false;  // no edge spans p.y
    const std::size_t n = polygon_.size();
    bool inside = false;
    const std::size_t s = slab(p.y());
    for (std::uint32_t e = start_[s]; e < start_[s + 1]; ++e) {
      const std::size_t i = edges_[e], j = i == 0 ? n - 1 : i - 1;
      if (crosses_ray(polygon_[i], polygon_[j], p)) inside = !inside;
    }
    return inside;
  }

 private:
  std::size_t slab(double y) const {
    const double s = std::floor((y - y0_) * scale_);
    return s <= 0 ? 0 : std::min(static_cast<std::size_t>(s), slabs_ - 1);
  }

  std::span<const Point2> polygon_;
  double y0_ = 0, y1_ = 0, scale_ = 0;
  std::size_t slabs_ = 0;
  std::vector<std::uint32_t> start_, edges_;
};

}  // namespace

ProjectabilityReport test_projectable(std::span<const Vec3> loop,
                                      std::span<const Vec3> outside_points,
                                      const ReferenceFrame& frame, double tolerance) {
  ProjectabilityReport r;
  std::vector<Point2> polygon;
  polygon.reserve(loop.size());
  for (const Vec3& p : loop) polygon.push_back(frame.project(p));
  double perimeter = 0;
  for (std::size_t i = 0; i < polygon.size(); ++i)
    perimeter += (polygon[(i + 1) % polygon.size()] - polygon[i]).norm();
  const double area = signed_area(polygon);
  const double disk = perimeter * perimeter / (4 * std::numbers::pi);
  r.signed_area_ratio = disk > 0 ? area / disk : 0;
  r.crossings = count_self_intersections(polygon);
  if (r.crossings > 0) {
    r.why_not = "boundary self-intersects in projection";
    return r;
  }
  if (!(area > 0)) {
    r.why_not = "boundary runs clockwise in projection";
    return r;
  }
  // Fold-over guard (ALGORITHMS.md §1.4 (3)): a surrounding triangle whose third vertex
  // projects well inside the hole polygon means the surface folds back over the plane.
  const SlabbedPolygon slabbed(polygon);
  for (const Vec3& q3 : outside_points) {
    const Point2 q = frame.project(q3);
    if (slabbed.contains(q) && !slabbed.near_edge(q, tolerance)) ++r.fold_overs;
  }
  if (r.fold_overs > 0) {
    r.why_not = "surrounding surface folds over the hole in projection";
    return r;
  }
  r.projectable = true;
  return r;
}

Vec3 pca_normal(std::span<const Vec3> points, const Vec3& hint) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const Vec3& p : points) mean += Eigen::Vector3d(p[0], p[1], p[2]);
  mean /= static_cast<double>(std::max<std::size_t>(1, points.size()));
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const Vec3& p : points) {
    const Eigen::Vector3d d = Eigen::Vector3d(p[0], p[1], p[2]) - mean;
    cov += d * d.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  const Eigen::Vector3d n = eig.eigenvectors().col(0);
  Vec3 out(n.x(), n.y(), n.z());
  if (OpenMesh::dot(out, hint) < 0) out = -out;
  return out;
}

}  // namespace touchmend::geometry
