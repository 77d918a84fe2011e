#pragma once

//! \file bvh.h
//! \brief A static bounding-volume hierarchy over triangles: box queries and closest points.

#include <cstdint>
#include <span>
#include <vector>

#include <Eigen/Geometry>

#include "server/geometry/intersection.h"
#include "server/geometry/mesh.h"

namespace touchmend::geometry {

using Box3 = Eigen::AlignedBox3d;

Box3 triangle_box(const TrianglePoints& t);

class TriangleBvh {
 public:
  TriangleBvh() = default;
  explicit TriangleBvh(std::vector<TrianglePoints> triangles);

  std::size_t size() const { return triangles_.size(); }
  const TrianglePoints& triangle(std::size_t i) const { return triangles_[i]; }

  //! Calls visit(triangle index) for every triangle in a leaf whose box overlaps \p box.
  template <typename Visit>
  void query_box(const Box3& box, Visit&& visit) const {
    for_each_leaf_triangle(box, [&](std::uint32_t i) {
      visit(i);
      return false;
    });
  }

  //! Whether any triangle's box overlaps \p box (stops at the first).
  bool overlaps_any(const Box3& box) const {
    return for_each_leaf_triangle(box, [&](std::uint32_t i) { return boxes_[i].intersects(box); });
  }

  struct Closest {
    double distance2 = 0;
    Vec3 point{0, 0, 0};
    std::uint32_t triangle = 0;
    bool found = false;
  };
  //! The closest point of any triangle to \p p.
  Closest closest_point(const Vec3& p) const;

 private:
  //! Walks the leaves whose boxes overlap \p box and calls stop(triangle index) for their
  //! triangles until it returns true; returns whether it did.
  template <typename Stop>
  bool for_each_leaf_triangle(const Box3& box, Stop&& stop) const {
    if (nodes_.empty()) return false;
    std::uint32_t stack[64];
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
      const Node& node = nodes_[stack[--top]];
      if (!node.box.intersects(box)) continue;
      if (node.count > 0) {
        for (std::uint32_t i = 0; i < node.count; ++i)
          if (stop(order_[node.first + i])) return true;
      } else if (top + 2 <= 64) {
        stack[top++] = node.first;
        stack[top++] = node.first + 1;
      }
    }
    return false;
  }

  struct Node {
    Box3 box;
    std::uint32_t first = 0;  // leaf: first index into order_; inner: left child (right = +1)
    std::uint32_t count = 0;  // leaf: triangle count; inner: 0
  };
  void build(std::uint32_t node, std::uint32_t begin, std::uint32_t end,
             const std::vector<Vec3>& centroids);

  std::vector<TrianglePoints> triangles_;
  std::vector<Box3> boxes_;
  std::vector<std::uint32_t> order_;
  std::vector<Node> nodes_;
};

}  // namespace touchmend::geometry
