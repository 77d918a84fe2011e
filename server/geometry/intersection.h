#pragma once

//! \file intersection.h
//! \brief Triangle-triangle intersection (with shared-vertex handling) and closest points.

#include <array>

#include "server/geometry/mesh.h"

namespace touchmend::geometry {

using TrianglePoints = std::array<Vec3, 3>;

//! Whether two mesh triangles intersect other than in the vertices and edge they legitimately
//! share. \p ids are vertex ids, used to find shared corners: with one shared vertex only an
//! intersection away from it counts; with a shared edge, only a fold-over (the two triangles
//! coplanar on the same side of the edge); three shared corners mean a duplicate face.
bool triangles_intersect(const TrianglePoints& t1, const std::array<int, 3>& ids1,
                         const TrianglePoints& t2, const std::array<int, 3>& ids2);

//! Whether segment [p, q] intersects triangle t (touching counts).
bool segment_intersects_triangle(const Vec3& p, const Vec3& q, const TrianglePoints& t);

//! The point of triangle t closest to p.
Vec3 closest_point_on_triangle(const Vec3& p, const TrianglePoints& t);

//! Squared distance between segments [p1, q1] and [p2, q2].
double segment_segment_distance2(const Vec3& p1, const Vec3& q1, const Vec3& p2, const Vec3& q2);

//! Distance between segment [p, q] and triangle t.
double segment_triangle_distance(const Vec3& p, const Vec3& q, const TrianglePoints& t);

}  // namespace touchmend::geometry
