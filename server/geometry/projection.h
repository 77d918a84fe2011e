#pragma once

//! \file projection.h
//! \brief Reference plane, rotation to +Z and the projectability test (seed 000 §3.4.1,
//! seed 001 §2.1, ALGORITHMS.md §1.4).

#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "server/geometry/mesh.h"

namespace touchmend::geometry {

using Point2 = Eigen::Vector2d;

//! Rotation that turns the reference plane's normal to +Z (rows e1, e2, n; det = +1), about
//! an origin. Projected coordinates are the first two rotated components; 3D positions are
//! never overwritten, so the thesis' "inverse rotation" (§3.4.3) needs no arithmetic.
struct ReferenceFrame {
  Vec3 origin{0, 0, 0};
  Vec3 e1{1, 0, 0};
  Vec3 e2{0, 1, 0};
  Vec3 normal{0, 0, 1};

  static ReferenceFrame from_normal(const Vec3& normal, const Vec3& origin);
  Point2 project(const Vec3& p) const {
    const Vec3 d = p - origin;
    return {OpenMesh::dot(d, e1), OpenMesh::dot(d, e2)};
  }
  Vec3 rotate(const Vec3& p) const {  //!< full rotation (z = height above the plane)
    const Vec3 d = p - origin;
    return {OpenMesh::dot(d, e1), OpenMesh::dot(d, e2), OpenMesh::dot(d, normal)};
  }
};

struct ProjectabilityReport {
  bool projectable = false;
  std::size_t crossings = 0;     //!< pairs of non-adjacent boundary edges that cross in 2D
  double signed_area_ratio = 0;  //!< projected signed area / (perimeter^2 / 4π), in [-1, 1]
  std::size_t fold_overs = 0;    //!< neighbour vertices projecting inside the hole polygon
  std::string why_not;
};

//! Tests whether \p loop (hole on the left) projects onto the plane of \p frame as a simple,
//! counter-clockwise polygon with no surrounding triangle folding over it.
//! \param outside_points third vertices of the mesh triangles along the boundary (may be
//!        empty); \param tolerance fold-over tolerance (0.05 x mean boundary edge length).
ProjectabilityReport test_projectable(std::span<const Vec3> loop,
                                      std::span<const Vec3> outside_points,
                                      const ReferenceFrame& frame, double tolerance);

//! Whether \p p lies inside the closed 2D polygon (even-odd rule).
bool point_in_polygon(std::span<const Point2> polygon, const Point2& p);

//! Signed area of a 2D polygon (positive when counter-clockwise).
double signed_area(std::span<const Point2> polygon);

//! Number of proper crossings between non-adjacent edges of a closed 2D polygon, plus
//! coincident vertices (O(n^2); fine for the hole sizes we meet, n <= a few thousand).
std::size_t count_self_intersections(std::span<const Point2> polygon);

//! Orientation of c relative to the directed line a->b: > 0 left, < 0 right.
inline double orient2d(const Point2& a, const Point2& b, const Point2& c) {
  return (b.x() - a.x()) * (c.y() - a.y()) - (b.y() - a.y()) * (c.x() - a.x());
}

//! True if segments [a,b] and [c,d] cross at a point interior to both (touching at an
//! endpoint or overlapping collinearly counts as crossing when \p count_touching).
bool segments_cross(const Point2& a, const Point2& b, const Point2& c, const Point2& d,
                    bool count_touching = false);

//! Unit normal of the least-squares plane of \p points (smallest principal axis), oriented
//! to agree with \p hint.
Vec3 pca_normal(std::span<const Vec3> points, const Vec3& hint);

}  // namespace touchmend::geometry
