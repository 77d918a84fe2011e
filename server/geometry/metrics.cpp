#include "server/geometry/metrics.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "server/geometry/bvh.h"

namespace touchmend::geometry {
namespace {

struct OneSided {
  double max = 0;
  double mean = 0;
  double normal_deviation_deg = 0;
};

OneSided one_sided(std::span<const TrianglePoints> from, const TriangleBvh& to, double spacing) {
  OneSided r;
  double weight_sum = 0, normal_weight = 0;
  for (const TrianglePoints& t : from) {
    const double longest =
        std::max({(t[1] - t[0]).norm(), (t[2] - t[1]).norm(), (t[0] - t[2]).norm()});
    const int k = std::clamp(static_cast<int>(std::ceil(longest / spacing)), 1, 400);
    const Vec3 nrm = OpenMesh::cross(t[1] - t[0], t[2] - t[0]);
    const double area = 0.5 * nrm.norm();
    const Vec3 unit = area > 0 ? nrm / (2 * area) : Vec3(0, 0, 0);
    const double samples = (k + 1) * (k + 2) / 2.0;
    const double w = area / samples;
    for (int i = 0; i <= k; ++i)
      for (int j = 0; j <= k - i; ++j) {
        const Vec3 p = t[0] + (t[1] - t[0]) * (static_cast<double>(i) / k) +
                       (t[2] - t[0]) * (static_cast<double>(j) / k);
        const TriangleBvh::Closest c = to.closest_point(p);
        const double d = std::sqrt(c.distance2);
        r.max = std::max(r.max, d);
        r.mean += w * d;
        weight_sum += w;
        // Normal deviation only at interior samples, where the closest face is unambiguous.
        if (i > 0 && j > 0 && i + j < k && area > 0) {
          const TrianglePoints& q = to.triangle(c.triangle);
          const Vec3 qn = OpenMesh::cross(q[1] - q[0], q[2] - q[0]).normalize_cond();
          const double angle = std::acos(std::clamp(OpenMesh::dot(unit, qn), -1.0, 1.0));
          r.normal_deviation_deg += w * angle * 180.0 / std::numbers::pi;
          normal_weight += w;
        }
      }
  }
  if (weight_sum > 0) r.mean /= weight_sum;
  if (normal_weight > 0) r.normal_deviation_deg /= normal_weight;
  return r;
}

}  // namespace

SurfaceDistance surface_distance(std::span<const TrianglePoints> a,
                                 std::span<const TrianglePoints> b, double spacing) {
  SurfaceDistance d;
  if (a.empty() || b.empty() || !(spacing > 0)) return d;
  const TriangleBvh bvh_a(std::vector<TrianglePoints>(a.begin(), a.end()));
  const TriangleBvh bvh_b(std::vector<TrianglePoints>(b.begin(), b.end()));
  const OneSided ab = one_sided(a, bvh_b, spacing);
  const OneSided ba = one_sided(b, bvh_a, spacing);
  d.h_a_to_b = ab.max;
  d.h_b_to_a = ba.max;
  d.hausdorff = std::max(ab.max, ba.max);
  d.mean_a_to_b = ab.mean;
  d.mean_b_to_a = ba.mean;
  d.mean = 0.5 * (ab.mean + ba.mean);
  d.normal_deviation_deg = ab.normal_deviation_deg;
  d.valid = true;
  return d;
}

SegmentDistance segment_distance(std::span<const std::array<Vec3, 2>> segments,
                                 std::span<const TrianglePoints> triangles, double spacing) {
  SegmentDistance d;
  if (segments.empty() || triangles.empty() || !(spacing > 0)) return d;
  const TriangleBvh bvh(std::vector<TrianglePoints>(triangles.begin(), triangles.end()));
  double weighted = 0, weight = 0;
  for (const auto& s : segments) {
    const double length = (s[1] - s[0]).norm();
    const int k = std::clamp(static_cast<int>(std::ceil(length / spacing)), 1, 1000);
    for (int i = 0; i <= k; ++i) {
      const Vec3 p = s[0] + (s[1] - s[0]) * (static_cast<double>(i) / k);
      const double dist = std::sqrt(bvh.closest_point(p).distance2);
      d.max = std::max(d.max, dist);
      weighted += length / (k + 1) * dist;
      weight += length / (k + 1);
    }
  }
  d.mean = weight > 0 ? weighted / weight : 0;
  d.valid = true;
  return d;
}

TriangleQuality triangle_quality(std::span<const TrianglePoints> triangles) {
  TriangleQuality q;
  for (const TrianglePoints& t : triangles) {
    const double a = (t[1] - t[2]).norm(), b = (t[2] - t[0]).norm(), c = (t[0] - t[1]).norm();
    const double area = 0.5 * OpenMesh::cross(t[1] - t[0], t[2] - t[0]).norm();
    const double longest = std::max({a, b, c});
    if (!(area > 1e-300) || !(longest > 0)) {
      ++q.degenerate;
      q.min_angle_deg = 0;
      continue;
    }
    // Angles by the law of cosines; the smallest is opposite the shortest edge.
    auto angle = [](double opp, double s1, double s2) {
      return std::acos(std::clamp((s1 * s1 + s2 * s2 - opp * opp) / (2 * s1 * s2), -1.0, 1.0));
    };
    const double min_angle =
        std::min({angle(a, b, c), angle(b, c, a), angle(c, a, b)}) * 180.0 / std::numbers::pi;
    q.min_angle_deg = std::min(q.min_angle_deg, min_angle);
    if (min_angle < 10) ++q.below_10_deg;
    const double inradius = 2 * area / (a + b + c);
    q.max_aspect_ratio = std::max(q.max_aspect_ratio, longest / (2 * std::sqrt(3.0) * inradius));
  }
  return q;
}

MeshSoup to_soup(const Mesh& mesh) {
  MeshSoup soup;
  std::vector<std::uint32_t> index(mesh.n_vertices(), 0);
  for (const VertexHandle v : mesh.vertices()) {
    index[static_cast<std::size_t>(v.idx())] = static_cast<std::uint32_t>(soup.points.size());
    soup.points.push_back(mesh.point(v));
  }
  for (const FaceHandle f : mesh.faces()) {
    Triangle t;
    int k = 0;
    for (const VertexHandle v : mesh.fv_range(f))
      t[static_cast<std::size_t>(k++)] = index[static_cast<std::size_t>(v.idx())];
    soup.triangles.push_back(t);
  }
  return soup;
}

ValidationReport validate_mesh(const Mesh& mesh) {
  return build_mesh(to_soup(mesh)).report;
}

double bounding_box_diagonal(const Mesh& mesh) {
  Box3 box;
  for (const VertexHandle v : mesh.vertices()) {
    const Vec3& p = mesh.point(v);
    box.extend(Eigen::Vector3d(p[0], p[1], p[2]));
  }
  return box.isEmpty() ? 0.0 : box.diagonal().norm();
}

std::vector<TrianglePoints> face_triangles(const Mesh& mesh, std::span<const FaceHandle> faces) {
  std::vector<TrianglePoints> out;
  out.reserve(faces.size());
  for (const FaceHandle f : faces) {
    TrianglePoints t;
    int k = 0;
    for (const VertexHandle v : mesh.fv_range(f)) t[static_cast<std::size_t>(k++)] = mesh.point(v);
    out.push_back(t);
  }
  return out;
}

}  // namespace touchmend::geometry
