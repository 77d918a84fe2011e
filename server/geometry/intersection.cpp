#include "server/geometry/intersection.h"

#include <algorithm>
#include <cmath>

namespace touchmend::geometry {
namespace {

int sign(double v, double eps) {
  return v > eps ? 1 : (v < -eps ? -1 : 0);
}

//! 2D tests for coplanar triangles, in the plane's dominant projection.
struct Flat {
  int ax, ay;
  explicit Flat(const Vec3& normal) {
    const Vec3 a(std::abs(normal[0]), std::abs(normal[1]), std::abs(normal[2]));
    if (a[0] >= a[1] && a[0] >= a[2]) {
      ax = 1;
      ay = 2;
    } else if (a[1] >= a[2]) {
      ax = 2;
      ay = 0;
    } else {
      ax = 0;
      ay = 1;
    }
  }
  double orient(const Vec3& a, const Vec3& b, const Vec3& c) const {
    return (b[ax] - a[ax]) * (c[ay] - a[ay]) - (b[ay] - a[ay]) * (c[ax] - a[ax]);
  }
};

bool coplanar_segments_cross(const Flat& f, const Vec3& a, const Vec3& b, const Vec3& c,
                             const Vec3& d) {
  const double d1 = f.orient(a, b, c), d2 = f.orient(a, b, d);
  const double d3 = f.orient(c, d, a), d4 = f.orient(c, d, b);
  return ((d1 > 0 && d2 < 0) || (d1 < 0 && d2 > 0)) && ((d3 > 0 && d4 < 0) || (d3 < 0 && d4 > 0));
}

bool coplanar_point_in_triangle(const Flat& f, const Vec3& p, const TrianglePoints& t) {
  const double s = f.orient(t[0], t[1], t[2]);
  const double d0 = f.orient(t[0], t[1], p), d1 = f.orient(t[1], t[2], p),
               d2 = f.orient(t[2], t[0], p);
  if (s > 0) return d0 > 0 && d1 > 0 && d2 > 0;
  return d0 < 0 && d1 < 0 && d2 < 0;
}

//! Proper overlap of two coplanar triangles (edges crossing or one corner strictly inside).
bool coplanar_triangles_overlap(const TrianglePoints& t1, const TrianglePoints& t2,
                                const Vec3& normal) {
  const Flat f(normal);
  // Separating axis first: if the line of one triangle's edge has the whole other triangle
  // strictly on its outer side, they cannot overlap. Neighbouring faces of a flat region are
  // almost always separated this way, and the test costs a few multiplications, against the
  // 9 segment-pair and 6 point-in-triangle tests below.
  const auto separated_by_an_edge_of = [&f](const TrianglePoints& a, const TrianglePoints& b) {
    for (int i = 0; i < 3; ++i) {
      const Vec3& p = a[i];
      const Vec3& q = a[(i + 1) % 3];
      const double inside = f.orient(p, q, a[(i + 2) % 3]);
      if (inside == 0) continue;
      bool all_outside = true;
      for (int k = 0; k < 3 && all_outside; ++k) all_outside = f.orient(p, q, b[k]) * inside < 0;
      if (all_outside) return true;
    }
    return false;
  };
  if (separated_by_an_edge_of(t1, t2) || separated_by_an_edge_of(t2, t1)) return false;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (coplanar_segments_cross(f, t1[i], t1[(i + 1) % 3], t2[j], t2[(j + 1) % 3])) return true;
  for (int i = 0; i < 3; ++i)
    if (coplanar_point_in_triangle(f, t1[i], t2) || coplanar_point_in_triangle(f, t2[i], t1))
      return true;
  // Identical corners but one triangle inside the other's centroid region.
  const Vec3 c1 = (t1[0] + t1[1] + t1[2]) / 3.0, c2 = (t2[0] + t2[1] + t2[2]) / 3.0;
  return coplanar_point_in_triangle(f, c1, t2) || coplanar_point_in_triangle(f, c2, t1);
}

}  // namespace

namespace {

//! What the segment test needs of a triangle (its plane and scale): prepare_triangle without
//! the ids and the side planes, which only the pair test reads.
PreparedTriangle prepare_plane(const TrianglePoints& t) {
  PreparedTriangle out;
  out.points = t;
  out.normal = OpenMesh::cross(t[1] - t[0], t[2] - t[0]);
  out.normal_norm = out.normal.norm();
  if (out.normal_norm > 0) out.unit_normal = out.normal / out.normal_norm;
  for (int i = 0; i < 3; ++i)
    out.longest_sqr = std::max(out.longest_sqr, (t[(i + 1) % 3] - t[i]).sqrnorm());
  out.longest = std::max({(t[1] - t[0]).norm(), (t[2] - t[0]).norm(), (t[2] - t[1]).norm()});
  return out;
}

}  // namespace

PreparedTriangle prepare_triangle(const TrianglePoints& t, const std::array<int, 3>& ids) {
  PreparedTriangle out = prepare_plane(t);
  out.ids = ids;
  if (out.normal_norm > 0)
    for (int i = 0; i < 3; ++i)
      out.side_inward[i] = OpenMesh::cross(out.normal, t[(i + 1) % 3] - t[i]).normalize_cond();
  return out;
}

namespace {

bool segment_intersects_prepared(const Vec3& p, const Vec3& q, const PreparedTriangle& prepared) {
  // Signed distances to the triangle's plane decide which side the ends are on; the crossing
  // point is then tested against the edges. Working with distances (not raw orientation
  // volumes) keeps the tolerance meaningful when the segment runs almost in the plane: a
  // line lying in the plane would otherwise make every volume "zero" and look like a hit.
  const TrianglePoints& t = prepared.points;
  const double nn = prepared.normal_norm;
  const double l = std::max(prepared.longest, (q - p).norm());
  if (!(nn > 1e-14 * l * l)) return false;  // degenerate triangle
  const Vec3& nh = prepared.unit_normal;
  const double eps = 1e-12 * l;
  const double dp = OpenMesh::dot(nh, p - t[0]), dq = OpenMesh::dot(nh, q - t[0]);
  if ((dp > eps && dq > eps) || (dp < -eps && dq < -eps)) return false;
  const Flat f(nh);
  if (std::abs(dp) <= eps && std::abs(dq) <= eps) {  // in the plane: 2D segment vs triangle
    for (int j = 0; j < 3; ++j)
      if (coplanar_segments_cross(f, p, q, t[j], t[(j + 1) % 3])) return true;
    return coplanar_point_in_triangle(f, p, t) || coplanar_point_in_triangle(f, q, t);
  }
  const Vec3 x =
      std::abs(dp) <= eps ? p : (std::abs(dq) <= eps ? q : p + (q - p) * (dp / (dp - dq)));
  for (int i = 0; i < 3; ++i) {
    const Vec3 e = t[(i + 1) % 3] - t[i];
    if (OpenMesh::dot(OpenMesh::cross(e, x - t[i]), nh) < -eps * e.norm()) return false;
  }
  return true;
}

//! Whether all of \p other lies farther than \p apart beyond a side of \p t: the plane through
//! that side perpendicular to \p t then separates the two (\p t lies on its inner side).
bool beyond_a_side(const PreparedTriangle& t, const TrianglePoints& other, double apart) {
  for (int i = 0; i < 3; ++i) {
    const Vec3& inward = t.side_inward[i];
    const Vec3& on_side = t.points[i];
    if (OpenMesh::dot(inward, other[0] - on_side) < -apart &&
        OpenMesh::dot(inward, other[1] - on_side) < -apart &&
        OpenMesh::dot(inward, other[2] - on_side) < -apart)
      return true;
  }
  return false;
}

//! orient3d(t[0], t[1], t[2], d), with the triangle's normal worked out once.
double orient_to(const PreparedTriangle& t, const Vec3& d) {
  return OpenMesh::dot(t.normal, d - t.points[0]);
}

}  // namespace

bool segment_intersects_triangle(const Vec3& p, const Vec3& q, const TrianglePoints& t) {
  return segment_intersects_prepared(p, q, prepare_plane(t));
}

bool triangles_intersect(const TrianglePoints& t1, const std::array<int, 3>& ids1,
                         const TrianglePoints& t2, const std::array<int, 3>& ids2) {
  return triangles_intersect(prepare_triangle(t1, ids1), prepare_triangle(t2, ids2));
}

bool triangles_intersect(const PreparedTriangle& p1, const PreparedTriangle& p2) {
  const TrianglePoints& t1 = p1.points;
  const TrianglePoints& t2 = p2.points;
  int shared = 0;
  int s1[3] = {-1, -1, -1}, s2[3] = {-1, -1, -1};  // position of shared corners
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (p1.ids[i] == p2.ids[j]) {
        s1[shared] = i;
        s2[shared] = j;
        ++shared;
      }
  const double l = std::sqrt(std::max(p1.longest_sqr, p2.longest_sqr));
  const double eps = 1e-14 * l * l * l;
  const Vec3& n1 = p1.normal;
  if (p1.normal_norm <= 1e-14 * l * l || p2.normal_norm <= 1e-14 * l * l)
    return false;  // degenerate
  if (shared == 3) return true;
  if (shared == 2) {
    // Only a fold-over can intersect: both coplanar, third corners on the same side.
    const int o1 = 3 - s1[0] - s1[1], o2 = 3 - s2[0] - s2[1];
    if (sign(orient_to(p1, t2[o2]), eps) != 0) return false;
    const Vec3& a = t1[s1[0]];
    const Vec3& b = t1[s1[1]];
    const Flat f(n1);
    return f.orient(a, b, t1[o1]) * f.orient(a, b, t2[o2]) > 0;
  }
  if (shared == 1) {
    const int i = s1[0], j = s2[0];
    // Quick reject: the other triangle's two free corners strictly on one side of the plane
    // means the two meet only at the shared corner (the common case for neighbours).
    const int c1 = sign(orient_to(p1, t2[(j + 1) % 3]), eps);
    const int c2 = sign(orient_to(p1, t2[(j + 2) % 3]), eps);
    if (c1 != 0 && c1 == c2) return false;
    const int q1 = sign(orient_to(p2, t1[(i + 1) % 3]), eps);
    const int q2 = sign(orient_to(p2, t1[(i + 2) % 3]), eps);
    if (q1 != 0 && q1 == q2) return false;
    // Any intersection away from the shared corner crosses an opposite edge (see header).
    const Vec3& a1 = t1[(i + 1) % 3];
    const Vec3& b1 = t1[(i + 2) % 3];
    const Vec3& a2 = t2[(j + 1) % 3];
    const Vec3& b2 = t2[(j + 2) % 3];
    if (c1 == 0 && c2 == 0) {  // coplanar fan: overlap if the wedges overlap
      // The triangles lie in their wedges at the shared corner; a line through that corner
      // along one triangle's edge with the other triangle's free corners strictly on the far
      // side separates them (they meet only at the corner). Fans of a flat patch are almost
      // always separated this way.
      const Flat f(n1);
      const Vec3& v = t1[i];
      const auto strictly_beyond = [&f, &v](const Vec3& ray, const Vec3& inside, const Vec3& p,
                                            const Vec3& q) {
        const double side = f.orient(v, ray, inside);
        return side * f.orient(v, ray, p) < 0 && side * f.orient(v, ray, q) < 0;
      };
      if (strictly_beyond(a1, b1, a2, b2) || strictly_beyond(b1, a1, a2, b2) ||
          strictly_beyond(a2, b2, a1, b1) || strictly_beyond(b2, a2, a1, b1)) {
        return false;
      }
      return coplanar_triangles_overlap(t1, t2, n1);
    }
    return segment_intersects_prepared(a1, b1, p2) || segment_intersects_prepared(a2, b2, p1);
  }
  // No shared corner: general position.
  const int d0 = sign(orient_to(p1, t2[0]), eps);
  const int d1 = sign(orient_to(p1, t2[1]), eps);
  const int d2 = sign(orient_to(p1, t2[2]), eps);
  if (d0 == d1 && d1 == d2 && d0 != 0) return false;
  // Beside each other, the two in (nearly) one plane: a side of either has all of the other
  // beyond it. The face around a patch on a CAD part (planar, long slivers whose boxes reach
  // far) mostly is; the tests below would take six segment tests to tell. The margin is a
  // thousand times the tolerances below: what they count as touching is not passed over (but
  // at the tip of a needle thinner than 0.1°, where their tolerance reaches that far).
  const double apart = 1e-9 * l;
  if (beyond_a_side(p1, t2, apart) || beyond_a_side(p2, t1, apart)) return false;
  if (d0 == 0 && d1 == 0 && d2 == 0) return coplanar_triangles_overlap(t1, t2, n1);
  const int e0 = sign(orient_to(p2, t1[0]), eps);
  const int e1 = sign(orient_to(p2, t1[1]), eps);
  const int e2 = sign(orient_to(p2, t1[2]), eps);
  if (e0 == e1 && e1 == e2 && e0 != 0) return false;
  for (int i = 0; i < 3; ++i) {
    if (segment_intersects_prepared(t1[i], t1[(i + 1) % 3], p2)) return true;
    if (segment_intersects_prepared(t2[i], t2[(i + 1) % 3], p1)) return true;
  }
  return false;
}

Vec3 closest_point_on_triangle(const Vec3& p, const TrianglePoints& t) {
  // Voronoi-region walk (Ericson, Real-Time Collision Detection, §5.1.5).
  const Vec3& a = t[0];
  const Vec3& b = t[1];
  const Vec3& c = t[2];
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = OpenMesh::dot(ab, ap), d2 = OpenMesh::dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Vec3 bp = p - b;
  const double d3 = OpenMesh::dot(ab, bp), d4 = OpenMesh::dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + ab * (d1 / (d1 - d3));
  const Vec3 cp = p - c;
  const double d5 = OpenMesh::dot(ab, cp), d6 = OpenMesh::dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + ac * (d2 / (d2 - d6));
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0)
    return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
  const double denom = va + vb + vc;
  if (!(std::abs(denom) > 0)) return a;  // degenerate triangle
  const double v = vb / denom, w = vc / denom;
  return a + ab * v + ac * w;
}

double segment_segment_distance2(const Vec3& p1, const Vec3& q1, const Vec3& p2, const Vec3& q2) {
  const Vec3 d1 = q1 - p1, d2 = q2 - p2, r = p1 - p2;
  const double a = d1.sqrnorm(), e = d2.sqrnorm(), f = OpenMesh::dot(d2, r);
  double s = 0, t = 0;
  if (a <= 1e-300 && e <= 1e-300) return r.sqrnorm();
  if (a <= 1e-300) {
    t = std::clamp(f / e, 0.0, 1.0);
  } else {
    const double c = OpenMesh::dot(d1, r);
    if (e <= 1e-300) {
      s = std::clamp(-c / a, 0.0, 1.0);
    } else {
      const double b = OpenMesh::dot(d1, d2);
      const double denom = a * e - b * b;
      s = denom > 0 ? std::clamp((b * f - c * e) / denom, 0.0, 1.0) : 0.0;
      t = (b * s + f) / e;
      if (t < 0) {
        t = 0;
        s = std::clamp(-c / a, 0.0, 1.0);
      } else if (t > 1) {
        t = 1;
        s = std::clamp((b - c) / a, 0.0, 1.0);
      }
    }
  }
  return ((p1 + d1 * s) - (p2 + d2 * t)).sqrnorm();
}

double segment_triangle_distance(const Vec3& p, const Vec3& q, const TrianglePoints& t) {
  if (segment_intersects_triangle(p, q, t)) return 0;
  double d2 = std::min((closest_point_on_triangle(p, t) - p).sqrnorm(),
                       (closest_point_on_triangle(q, t) - q).sqrnorm());
  for (int i = 0; i < 3; ++i)
    d2 = std::min(d2, segment_segment_distance2(p, q, t[i], t[(i + 1) % 3]));
  return std::sqrt(d2);
}

}  // namespace touchmend::geometry
