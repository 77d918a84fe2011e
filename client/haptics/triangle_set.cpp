#include "client/haptics/triangle_set.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace touchmend::haptics {
namespace {

constexpr int kStackSize = 64;  // depth of a median-split tree over 2^32 triangles is < 64
constexpr std::uint32_t kLeafSize = 4;

//! Slab test: does the segment p + t·d, t in [0, t_max], meet the box?
bool segment_meets_box(const Eigen::AlignedBox3d& box, const Vec3& p, const Vec3& inv_d,
                       double t_max) {
  double t0 = 0, t1 = t_max;
  for (int k = 0; k < 3; ++k) {
    double a = (box.min()[k] - p[k]) * inv_d[k];
    double b = (box.max()[k] - p[k]) * inv_d[k];
    if (a > b) std::swap(a, b);
    // NaN (0 * inf, a segment lying in a slab's plane) compares false: keep the range.
    if (a > t0) t0 = a;
    if (b < t1) t1 = b;
    if (t0 > t1) return false;
  }
  return true;
}

bool segment_triangle(const Vec3& p, const Vec3& d, const std::array<Vec3, 3>& tri, double& t) {
  const Vec3 e1 = tri[1] - tri[0], e2 = tri[2] - tri[0];
  const Vec3 pvec = d.cross(e2);
  const double det = e1.dot(pvec);
  // Parallel (relative to the sizes involved): no single crossing point.
  if (std::abs(det) <= 1e-12 * e1.norm() * e2.norm() * d.norm()) return false;
  const double inv = 1.0 / det;
  const Vec3 tvec = p - tri[0];
  // A small tolerance on the barycentric bounds: a segment through a shared edge or vertex
  // must hit at least one of the triangles there, whatever the rounding (no leak between
  // neighbours); hitting both is harmless (same t).
  constexpr double kSlack = 1e-9;
  const double u = tvec.dot(pvec) * inv;
  if (u < -kSlack || u > 1 + kSlack) return false;
  const Vec3 qvec = tvec.cross(e1);
  const double v = d.dot(qvec) * inv;
  if (v < -kSlack || u + v > 1 + kSlack) return false;
  t = e2.dot(qvec) * inv;
  return t >= 0 && t <= 1;
}

}  // namespace

Vec3 closest_on_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Vec3 bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + (d1 / (d1 - d3)) * ab;
  const Vec3 cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + (d2 / (d2 - d6)) * ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0)
    return b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
  const double denom = 1.0 / (va + vb + vc);
  return a + ab * (vb * denom) + ac * (vc * denom);
}

void TriangleSet::clear() {
  corners_.clear();
  normals_.clear();
  face_ids_.clear();
  nodes_.clear();
  bounds_.setEmpty();
}

void TriangleSet::build(const SurfaceMesh& mesh, std::span<const std::uint32_t> which) {
  clear();
  const std::size_t n = which.empty() ? mesh.triangles.size() : which.size();
  corners_.reserve(n);
  face_ids_.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint32_t t = which.empty() ? static_cast<std::uint32_t>(i) : which[i];
    const auto& tri = mesh.triangles[t];
    corners_.push_back({mesh.positions[tri[0]], mesh.positions[tri[1]], mesh.positions[tri[2]]});
    face_ids_.push_back(t < mesh.face_ids.size() ? mesh.face_ids[t] : t);
  }
  finish_build();
}

void TriangleSet::build_from(const TriangleSet& source, std::span<const std::uint32_t> which) {
  clear();
  corners_.reserve(which.size());
  face_ids_.reserve(which.size());
  for (const std::uint32_t t : which) {
    corners_.push_back(source.corners_[t]);
    face_ids_.push_back(source.face_ids_[t]);
  }
  finish_build();
}

void TriangleSet::finish_build() {
  const auto n = static_cast<std::uint32_t>(corners_.size());
  order_.resize(n);
  centroids_.resize(n);
  for (std::uint32_t i = 0; i < n; ++i) {
    order_[i] = i;
    centroids_[i] = (corners_[i][0] + corners_[i][1] + corners_[i][2]) / 3.0;
  }
  nodes_.reserve(n == 0 ? 1 : 2 * (n / kLeafSize + 1));
  if (n > 0) build_node(0, n, centroids_);
  // Store the triangles in leaf order so a leaf's triangles are contiguous.
  std::vector<std::array<Vec3, 3>> corners(n);
  std::vector<std::uint32_t> ids(n);
  for (std::uint32_t i = 0; i < n; ++i) {
    corners[i] = corners_[order_[i]];
    ids[i] = face_ids_[order_[i]];
  }
  corners_.swap(corners);
  face_ids_.swap(ids);
  normals_.resize(n);
  for (std::uint32_t i = 0; i < n; ++i) {
    const Vec3 nrm = (corners_[i][1] - corners_[i][0]).cross(corners_[i][2] - corners_[i][0]);
    const double len = nrm.norm();
    normals_[i] = len > 0 ? Vec3(nrm / len) : Vec3(0, 0, 1);
  }
  bounds_ = nodes_.empty() ? Eigen::AlignedBox3d() : nodes_[0].box;
}

std::uint32_t TriangleSet::build_node(std::uint32_t begin, std::uint32_t end,
                                      std::vector<Vec3>& centroids) {
  const auto index = static_cast<std::uint32_t>(nodes_.size());
  nodes_.emplace_back();
  Eigen::AlignedBox3d box, centre_box;
  for (std::uint32_t i = begin; i < end; ++i) {
    for (const Vec3& c : corners_[order_[i]]) box.extend(c);
    centre_box.extend(centroids[order_[i]]);
  }
  nodes_[index].box = box;
  if (end - begin <= kLeafSize) {
    nodes_[index].first = begin;
    nodes_[index].count = end - begin;
    return index;
  }
  int axis = 0;
  centre_box.diagonal().maxCoeff(&axis);
  const std::uint32_t mid = begin + (end - begin) / 2;
  std::nth_element(
      order_.begin() + begin, order_.begin() + mid, order_.begin() + end,
      [&](std::uint32_t a, std::uint32_t b) { return centroids[a][axis] < centroids[b][axis]; });
  build_node(begin, mid, centroids);
  const std::uint32_t right = build_node(mid, end, centroids);
  nodes_[index].first = right;
  nodes_[index].count = 0;
  return index;
}

bool TriangleSet::first_hit(const Vec3& a, const Vec3& b, SegmentHit& hit) const {
  last_tests = 0;
  if (nodes_.empty()) return false;
  const Vec3 d = b - a;
  const Vec3 inv_d(1.0 / d.x(), 1.0 / d.y(), 1.0 / d.z());
  double best = std::numeric_limits<double>::infinity();
  std::uint32_t stack[kStackSize];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& node = nodes_[stack[--top]];
    if (!segment_meets_box(node.box, a, inv_d, std::min(best, 1.0))) continue;
    if (node.count > 0) {
      for (std::uint32_t i = node.first; i < node.first + node.count; ++i) {
        ++last_tests;
        double t = 0;
        if (segment_triangle(a, d, corners_[i], t) && t < best) {
          best = t;
          hit.t = t;
          hit.triangle = i;
        }
      }
      continue;
    }
    const std::uint32_t self = static_cast<std::uint32_t>(&node - nodes_.data());
    if (top + 2 > kStackSize) return false;  // cannot happen for median-split trees
    stack[top++] = node.first;               // right
    stack[top++] = self + 1;                 // left first
  }
  if (!std::isfinite(best)) return false;
  hit.point = a + hit.t * d;
  return true;
}

bool TriangleSet::closest(const Vec3& p, double max_distance, ClosestHit& hit) const {
  last_tests = 0;
  if (nodes_.empty()) return false;
  double best_sq = max_distance * max_distance;
  bool found = false;
  std::uint32_t stack[kStackSize];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& node = nodes_[stack[--top]];
    if (node.box.squaredExteriorDistance(p) > best_sq) continue;
    if (node.count > 0) {
      for (std::uint32_t i = node.first; i < node.first + node.count; ++i) {
        ++last_tests;
        const Vec3 q = closest_on_triangle(p, corners_[i][0], corners_[i][1], corners_[i][2]);
        const double d2 = (q - p).squaredNorm();
        if (d2 <= best_sq) {
          best_sq = d2;
          hit.triangle = i;
          hit.point = q;
          found = true;
        }
      }
      continue;
    }
    const std::uint32_t self = static_cast<std::uint32_t>(&node - nodes_.data());
    if (top + 2 > kStackSize) return found;
    // Visit the nearer child first.
    const std::uint32_t left = self + 1, right = node.first;
    const bool left_first =
        nodes_[left].box.squaredExteriorDistance(p) <= nodes_[right].box.squaredExteriorDistance(p);
    stack[top++] = left_first ? right : left;
    stack[top++] = left_first ? left : right;
  }
  if (found) hit.distance = std::sqrt(best_sq);
  return found;
}

std::size_t TriangleSet::in_sphere(const Vec3& centre, double radius,
                                   std::vector<std::uint32_t>& out) const {
  out.clear();
  if (nodes_.empty()) return 0;
  const double r2 = radius * radius;
  std::uint32_t stack[kStackSize];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& node = nodes_[stack[--top]];
    if (node.box.squaredExteriorDistance(centre) > r2) continue;
    if (node.count > 0) {
      for (std::uint32_t i = node.first; i < node.first + node.count; ++i) {
        Eigen::AlignedBox3d box;
        for (const Vec3& c : corners_[i]) box.extend(c);
        if (box.squaredExteriorDistance(centre) <= r2) out.push_back(i);
      }
      continue;
    }
    const std::uint32_t self = static_cast<std::uint32_t>(&node - nodes_.data());
    if (top + 2 > kStackSize) break;
    stack[top++] = node.first;
    stack[top++] = self + 1;
  }
  return out.size();
}

}  // namespace touchmend::haptics
