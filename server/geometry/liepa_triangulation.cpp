#include "server/geometry/liepa_triangulation.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_set>

#include <fmt/format.h>

#include "server/geometry/intersection.h"

namespace touchmend::geometry {
namespace {

struct Weight {
  double angle = 0;  // largest dihedral deviation, radians
  double area = 0;
  //! Smallest triangle angle, as the min_angle_sine of intersection.h (larger is better).
  double shape = 1;
  // Angles closer than kAngleTie (in the bend measure below, ~1e-9 rad) are equal, so that
  // coplanar candidates, whose angles differ only by rounding, are ranked by area as the
  // weight intends.
  static constexpr double kAngleTie = 1e-18;
  // Every triangulation of a planar polygon has the same area, so areas that differ only by
  // rounding are equal too, and then the triangulation whose worst triangle is best wins (our
  // third term: Liepa's weight leaves such ties to chance, which on the straight runs of a
  // CAD part's hole picks slivers).
  static constexpr double kAreaTie = 1e-9;
  bool operator<(const Weight& o) const {
    if (std::abs(angle - o.angle) > kAngleTie) return angle < o.angle;
    if (std::abs(area - o.area) > kAreaTie * std::max(area, o.area)) return area < o.area;
    return shape > o.shape;
  }
  Weight operator+(const Weight& o) const {
    return {std::max(angle, o.angle), area + o.area, std::min(shape, o.shape)};
  }
};

constexpr Weight kInvalid{std::numeric_limits<double>::infinity(),
                          std::numeric_limits<double>::infinity(), 0.0};

//! A measure of the angle between unit normals that grows with the angle on [0, π] and needs
//! no trigonometry (the DP evaluates it O(n^3) times): sin² below 90°, 2 - sin² above. It is
//! accurate near 0, where 1 - cos would lose half the digits.
double angle_between(const Vec3& n1, const Vec3& n2) {
  const double s2 = OpenMesh::cross(n1, n2).sqrnorm();
  return OpenMesh::dot(n1, n2) >= 0 ? s2 : 2.0 - s2;
}

}  // namespace

LiepaTriangulation triangulate_min_dihedral(std::span<const Vec3> loop,
                                            std::span<const Vec3> opposite,
                                            std::span<const std::pair<int, int>> blocked,
                                            const LiepaTriangulationOptions& options) {
  LiepaTriangulation out;
  const int n = static_cast<int>(loop.size());
  if (n < 3) {
    out.failure = "fewer than 3 boundary vertices";
    return out;
  }
  if (static_cast<std::size_t>(n) > options.max_vertices) {
    out.failure = fmt::format(
        "{} boundary vertices exceed the {}-vertex limit of the 3D "
        "minimum-weight triangulation",
        n, options.max_vertices);
    return out;
  }
  std::unordered_set<long long> blocked_set;
  for (const auto& [a, b] : blocked)
    blocked_set.insert(static_cast<long long>(std::min(a, b)) * n + std::max(a, b));
  auto is_blocked = [&](int a, int b) {
    if (std::abs(a - b) == 1 || std::abs(a - b) == n - 1) return false;  // boundary edge
    return blocked_set.count(static_cast<long long>(std::min(a, b)) * n + std::max(a, b)) != 0;
  };
  auto unit_normal = [](const Vec3& a, const Vec3& b, const Vec3& c, double& area) {
    Vec3 nrm = OpenMesh::cross(b - a, c - a);
    const double len = nrm.norm();
    area = 0.5 * len;
    return len > 0 ? nrm / len : nrm;
  };
  double mean_edge = 0;
  for (int i = 0; i < n; ++i) mean_edge += (loop[(i + 1) % n] - loop[i]).norm();
  mean_edge /= n;
  const double min_area = 1e-12 * mean_edge * mean_edge;

  // Normals of the mesh triangles across each boundary edge i -> i+1.
  std::vector<Vec3> boundary_normal(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    double a;
    // The mesh triangle holds face-edge (i+1 -> i).
    boundary_normal[i] = unit_normal(loop[(i + 1) % n], loop[i], opposite[i], a);
  }
  const std::size_t N = static_cast<std::size_t>(n);
  std::vector<Weight> W(N * N);
  std::vector<int> lambda(N * N, -1);
  auto at = [N](int i, int k) {
    return static_cast<std::size_t>(i) * N + static_cast<std::size_t>(k);
  };
  // Normal of the triangle chosen for the sub-polygon (i, k), needed as the neighbour across
  // edge (i, k) by the parent.
  std::vector<Vec3> chosen_normal(N * N, Vec3(0, 0, 0));
  for (int i = 0; i + 1 < n; ++i) W[at(i, i + 1)] = Weight{};
  for (int len = 2; len < n; ++len) {
    for (int i = 0; i + len < n; ++i) {
      const int k = i + len;
      Weight best = kInvalid;
      int best_m = -1;
      Vec3 best_normal(0, 0, 0);
      if (is_blocked(i, k)) {
        W[at(i, k)] = kInvalid;
        continue;
      }
      for (int m = i + 1; m < k; ++m) {
        const Weight& left = W[at(i, m)];
        const Weight& right = W[at(m, k)];
        if (!(left.angle < kInvalid.angle) || !(right.angle < kInvalid.angle)) continue;
        // The combined weight's angle is at least the larger of the two parts': when that
        // already loses to the best so far, this candidate cannot win (no triangle to build).
        if (std::max(left.angle, right.angle) > best.angle + Weight::kAngleTie) continue;
        if (options.forbidden && options.forbidden->count(forbidden_key(i, m, k, n))) continue;
        double area;
        const Vec3 nrm = unit_normal(loop[i], loop[m], loop[k], area);
        if (area <= min_area) continue;
        // Dihedral deviation against the known neighbours across (i, m) and (m, k).
        const Vec3& n_im = (m == i + 1) ? boundary_normal[i] : chosen_normal[at(i, m)];
        const Vec3& n_mk = (k == m + 1) ? boundary_normal[m] : chosen_normal[at(m, k)];
        double angle = std::max(angle_between(nrm, n_im), angle_between(nrm, n_mk));
        if (i == 0 && k == n - 1)
          angle = std::max(angle, angle_between(nrm, boundary_normal[n - 1]));
        const Weight w =
            left + right + Weight{angle, area, min_angle_sine(loop[i], loop[m], loop[k], 2 * area)};
        if (w < best) {
          best = w;
          best_m = m;
          best_normal = nrm;
        }
      }
      W[at(i, k)] = best;
      lambda[at(i, k)] = best_m;
      chosen_normal[at(i, k)] = best_normal;
    }
  }
  if (lambda[at(0, n - 1)] < 0) {
    out.failure = "no valid 3D triangulation (every candidate is degenerate or reuses an edge)";
    return out;
  }
  std::vector<std::pair<int, int>> stack{{0, n - 1}};
  while (!stack.empty()) {
    const auto [i, k] = stack.back();
    stack.pop_back();
    if (k - i < 2) continue;
    const int m = lambda[at(i, k)];
    out.triangles.push_back({i, m, k});
    stack.emplace_back(i, m);
    stack.emplace_back(m, k);
  }
  out.ok = true;
  return out;
}

}  // namespace touchmend::geometry
