#pragma once

//! \file intersection.h
//! \brief Triangle primitives: intersection (with shared-vertex handling), closest points, and
//! the shape measure the triangulations and the quality pass compare triangles by.

#include <array>
#include <cmath>

#include "server/geometry/mesh.h"

namespace touchmend::geometry {

using TrianglePoints = std::array<Vec3, 3>;

//! Whether two mesh triangles intersect other than in the vertices and edge they legitimately
//! share. \p ids are vertex ids, used to find shared corners: with one shared vertex only an
//! intersection away from it counts; with a shared edge, only a fold-over (the two triangles
//! coplanar on the same side of the edge); three shared corners mean a duplicate face.
bool triangles_intersect(const TrianglePoints& t1, const std::array<int, 3>& ids1,
                         const TrianglePoints& t2, const std::array<int, 3>& ids2);

//! What the pair test needs of one triangle, worked out once: a triangle tested against many
//! (a patch triangle against the faces around it) pays for its normal and sides once. The
//! results are exactly those of triangles_intersect on the points (the same arithmetic).
struct PreparedTriangle {
  TrianglePoints points;
  std::array<int, 3> ids{};
  Vec3 normal{0, 0, 0};       //!< (p1 - p0) x (p2 - p0)
  double normal_norm = 0;     //!< |normal|
  Vec3 unit_normal{0, 0, 0};  //!< normal / |normal| (where |normal| > 0)
  double longest_sqr = 0;     //!< the longest side, squared
  double longest = 0;         //!< the longest of |p1 - p0|, |p2 - p0|, |p2 - p1|
  //! Unit normal of the plane through side i (p_i to p_i+1) perpendicular to the triangle,
  //! pointing into it (zero for a degenerate triangle).
  std::array<Vec3, 3> side_inward{};
};
PreparedTriangle prepare_triangle(const TrianglePoints& t, const std::array<int, 3>& ids);
bool triangles_intersect(const PreparedTriangle& t1, const PreparedTriangle& t2);

//! Whether segment [p, q] intersects triangle t (touching counts).
bool segment_intersects_triangle(const Vec3& p, const Vec3& q, const TrianglePoints& t);

//! The point of triangle t closest to p.
Vec3 closest_point_on_triangle(const Vec3& p, const TrianglePoints& t);

//! Squared distance between segments [p1, q1] and [p2, q2].
double segment_segment_distance2(const Vec3& p1, const Vec3& q1, const Vec3& p2, const Vec3& q2);

//! Distance between segment [p, q] and triangle t.
double segment_triangle_distance(const Vec3& p, const Vec3& q, const TrianglePoints& t);

//! sin of a triangle's smallest angle, given twice its area: the angle is the one opposite the
//! shortest side and never above 60°, where the sine grows with the angle, so comparing these
//! compares smallest angles without trigonometry (evaluated O(n³) times by the 3D
//! triangulation and for every candidate move of the quality pass, hence inline).
inline double min_angle_sine(const Vec3& a, const Vec3& b, const Vec3& c, double twice_area) {
  const double ab = (b - a).sqrnorm(), bc = (c - b).sqrnorm(), ca = (a - c).sqrnorm();
  double product;  // the two sides at the smallest angle
  if (ab <= bc && ab <= ca)
    product = bc * ca;
  else if (bc <= ca)
    product = ab * ca;
  else
    product = ab * bc;
  return product > 0 ? twice_area / std::sqrt(product) : 0.0;
}

inline double min_angle_sine(const Vec3& a, const Vec3& b, const Vec3& c) {
  return min_angle_sine(a, b, c, OpenMesh::cross(b - a, c - a).norm());
}

//! cos of a triangle's largest angle (opposite the longest side); -1 for a degenerate one.
inline double largest_angle_cos(const Vec3& a, const Vec3& b, const Vec3& c) {
  const double ab = (b - a).sqrnorm(), bc = (c - b).sqrnorm(), ca = (a - c).sqrnorm();
  double x, y, z;  // z: the longest side, squared
  if (ab >= bc && ab >= ca) {
    z = ab, x = bc, y = ca;
  } else if (bc >= ca) {
    z = bc, x = ab, y = ca;
  } else {
    z = ca, x = ab, y = bc;
  }
  const double denominator = 2 * std::sqrt(x * y);
  return denominator > 0 ? (x + y - z) / denominator : -1.0;
}

}  // namespace touchmend::geometry
