#include "server/geometry/bvh.h"

#include <algorithm>
#include <limits>
#include <numeric>

namespace touchmend::geometry {

Box3 triangle_box(const TrianglePoints& t) {
  Box3 b;
  for (const Vec3& p : t) b.extend(Eigen::Vector3d(p[0], p[1], p[2]));
  return b;
}

TriangleBvh::TriangleBvh(std::vector<TrianglePoints> triangles) : triangles_(std::move(triangles)) {
  const auto n = static_cast<std::uint32_t>(triangles_.size());
  if (n == 0) return;
  boxes_.reserve(n);
  std::vector<Vec3> centroids;
  centroids.reserve(n);
  for (const TrianglePoints& t : triangles_) {
    boxes_.push_back(triangle_box(t));
    centroids.push_back((t[0] + t[1] + t[2]) / 3.0);
  }
  order_.resize(n);
  std::iota(order_.begin(), order_.end(), 0u);
  nodes_.reserve(2 * static_cast<std::size_t>(n) / 4 + 2);
  nodes_.emplace_back();
  build(0, 0, n, centroids);
}

void TriangleBvh::build(std::uint32_t node_index, std::uint32_t begin, std::uint32_t end,
                        const std::vector<Vec3>& centroids) {
  Box3 box;
  Box3 centroid_box;
  for (std::uint32_t i = begin; i < end; ++i) {
    box.extend(boxes_[order_[i]]);
    const Vec3& c = centroids[order_[i]];
    centroid_box.extend(Eigen::Vector3d(c[0], c[1], c[2]));
  }
  nodes_[node_index].box = box;
  constexpr std::uint32_t kLeafSize = 4;
  if (end - begin <= kLeafSize) {
    nodes_[node_index].first = begin;
    nodes_[node_index].count = end - begin;
    return;
  }
  int axis;
  centroid_box.sizes().maxCoeff(&axis);
  const std::uint32_t mid = begin + (end - begin) / 2;
  std::nth_element(
      order_.begin() + begin, order_.begin() + mid, order_.begin() + end,
      [&](std::uint32_t a, std::uint32_t b) { return centroids[a][axis] < centroids[b][axis]; });
  const auto left = static_cast<std::uint32_t>(nodes_.size());
  nodes_.emplace_back();
  nodes_.emplace_back();
  nodes_[node_index].first = left;
  nodes_[node_index].count = 0;
  build(left, begin, mid, centroids);
  build(left + 1, mid, end, centroids);
}

TriangleBvh::Closest TriangleBvh::closest_point(const Vec3& p) const {
  Closest best;
  best.distance2 = std::numeric_limits<double>::infinity();
  if (nodes_.empty()) return best;
  const Eigen::Vector3d q(p[0], p[1], p[2]);
  std::uint32_t stack[64];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& node = nodes_[stack[--top]];
    if (node.box.squaredExteriorDistance(q) >= best.distance2) continue;
    if (node.count > 0) {
      for (std::uint32_t i = 0; i < node.count; ++i) {
        const std::uint32_t t = order_[node.first + i];
        const Vec3 c = closest_point_on_triangle(p, triangles_[t]);
        const double d2 = (c - p).sqrnorm();
        if (d2 < best.distance2) {
          best.distance2 = d2;
          best.point = c;
          best.triangle = t;
          best.found = true;
        }
      }
    } else if (top + 2 <= 64) {
      const Node& l = nodes_[node.first];
      const Node& r = nodes_[node.first + 1];
      const double dl = l.box.squaredExteriorDistance(q), dr = r.box.squaredExteriorDistance(q);
      // Visit the nearer child first (pushed last).
      if (dl < dr) {
        stack[top++] = node.first + 1;
        stack[top++] = node.first;
      } else {
        stack[top++] = node.first;
        stack[top++] = node.first + 1;
      }
    }
  }
  return best;
}

}  // namespace touchmend::geometry
