#pragma once

//! \file triangle_set.h
//! \brief Triangles in a flattened bounding-volume hierarchy: the haptic thread's proxy
//! surface (a local patch around the tool) and the proxy-update thread's whole-mesh index.
//!
//! \details Each triangle keeps its three corners (not indices: a query touches one cache
//! line per triangle), its unit normal and the document face id it came from. Nodes are in
//! depth-first order (the left child follows its parent), leaves hold up to four triangles,
//! splits are at the median centroid along the longest axis. Queries use a fixed-size stack
//! and never allocate (HAPTICS.md §6.2: CHAI3D's per-query std::vector is what to avoid).
//! build() allocates; it runs on the proxy-update thread, never on the haptic thread.

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace touchmend::haptics {

using Vec3 = Eigen::Vector3d;

//! A client's copy of the session mesh: positions and triangles (document slots; dead faces
//! are simply not listed).
struct SurfaceMesh {
  std::uint64_t version = 0;
  std::vector<Vec3> positions;
  std::vector<std::array<std::uint32_t, 3>> triangles;
  std::vector<std::uint32_t> face_ids;  //!< document face id of each triangle
};

struct SegmentHit {
  double t = 0;  //!< along the segment, in [0, 1]
  std::uint32_t triangle = 0;
  Vec3 point = Vec3::Zero();
};

struct ClosestHit {
  double distance = 0;
  std::uint32_t triangle = 0;
  Vec3 point = Vec3::Zero();
};

class TriangleSet {
 public:
  //! Rebuilds from \p mesh's triangles \p which (all when empty).
  void build(const SurfaceMesh& mesh, std::span<const std::uint32_t> which = {});
  //! Rebuilds from triangles of another set (a patch cut out of the whole-mesh index).
  void build_from(const TriangleSet& source, std::span<const std::uint32_t> which);
  void clear();

  std::size_t size() const { return corners_.size(); }
  bool empty() const { return corners_.empty(); }
  const std::array<Vec3, 3>& corners(std::uint32_t t) const { return corners_[t]; }
  const Vec3& normal(std::uint32_t t) const { return normals_[t]; }
  std::uint32_t face_id(std::uint32_t t) const { return face_ids_[t]; }
  const Eigen::AlignedBox3d& bounds() const { return bounds_; }

  //! The first triangle the segment a→b meets (two-sided); false if none.
  bool first_hit(const Vec3& a, const Vec3& b, SegmentHit& hit) const;
  //! The closest point within \p max_distance; false if none.
  bool closest(const Vec3& p, double max_distance, ClosestHit& hit) const;
  //! Triangles whose boxes meet the sphere; returns how many were written (up to out.size()).
  std::size_t in_sphere(const Vec3& centre, double radius, std::vector<std::uint32_t>& out) const;

  //! Number of triangle tests done by the last query (for benchmarks).
  mutable std::uint32_t last_tests = 0;

 private:
  struct Node {
    Eigen::AlignedBox3d box;
    std::uint32_t first = 0;  //!< leaf: first triangle; inner: index of the right child
    std::uint32_t count = 0;  //!< leaf: triangle count (0 = inner node)
  };
  void finish_build();
  std::uint32_t build_node(std::uint32_t begin, std::uint32_t end, std::vector<Vec3>& centroids);

  std::vector<std::array<Vec3, 3>> corners_;
  std::vector<Vec3> normals_;
  std::vector<std::uint32_t> face_ids_;
  std::vector<Node> nodes_;
  std::vector<std::uint32_t> order_;  // build scratch
  std::vector<Vec3> centroids_;       // build scratch
  Eigen::AlignedBox3d bounds_;
};

//! Closest point on a triangle (Ericson's region test).
Vec3 closest_on_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c);

}  // namespace touchmend::haptics
