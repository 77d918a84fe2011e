#include "server/geometry/ear_clipping.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>

#include <fmt/format.h>

namespace touchmend::geometry {
namespace {

Vec3 unit_normal(const Vec3& a, const Vec3& b, const Vec3& c) {
  return OpenMesh::cross(b - a, c - a).normalize_cond();
}

double angle(const Vec3& u, const Vec3& v) {
  return std::acos(std::clamp(OpenMesh::dot(u, v), -1.0, 1.0));
}

//! sin of the smallest angle (opposite the shortest side).
double shape(const Vec3& a, const Vec3& b, const Vec3& c) {
  const double ab = (b - a).sqrnorm(), bc = (c - b).sqrnorm(), ca = (a - c).sqrnorm();
  const double product = ab <= bc && ab <= ca ? bc * ca : (bc <= ca ? ab * ca : ab * bc);
  return product > 0 ? OpenMesh::cross(b - a, c - a).norm() / std::sqrt(product) : 0.0;
}

}  // namespace

EarClipping clip_ears(const EarClippingInput& in) {
  EarClipping out;
  const int n = static_cast<int>(in.loop.size());
  if (n < 3) {
    out.failure = "fewer than 3 boundary vertices";
    return out;
  }
  const auto P = [&](int i) -> const Vec3& { return in.loop[static_cast<std::size_t>(i)]; };
  double mean_edge = 0;
  for (int i = 0; i < n; ++i) mean_edge += (P((i + 1) % n) - P(i)).norm();
  mean_edge /= n;
  const double min_area = 1e-10 * mean_edge * mean_edge;

  std::vector<int> next(static_cast<std::size_t>(n)), prev(static_cast<std::size_t>(n));
  // across[a]: normal of the triangle on the far side of the polygon edge a -> next[a].
  std::vector<Vec3> across(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    next[static_cast<std::size_t>(i)] = (i + 1) % n;
    prev[static_cast<std::size_t>(i)] = (i + n - 1) % n;
    across[static_cast<std::size_t>(i)] =
        unit_normal(P((i + 1) % n), P(i), in.opposite[static_cast<std::size_t>(i)]);
  }
  std::set<std::pair<int, int>> edges;  // loop pairs joined by a mesh edge or a cut
  for (const auto& [a, b] : in.blocked) edges.insert({std::min(a, b), std::max(a, b)});
  std::vector<char> set_aside(static_cast<std::size_t>(n), 0);
  std::vector<TrianglePoints> cut;
  std::vector<std::array<int, 3>> cut_ids;

  const auto crosses_cut = [&](const std::array<int, 3>& corners) {
    const TrianglePoints t{P(corners[0]), P(corners[1]), P(corners[2])};
    for (std::size_t e = 0; e < cut.size(); ++e)
      if (triangles_intersect(t, corners, cut[e], cut_ids[e])) return true;
    return false;
  };
  // Cost of the ear at i (lower first); infinity when it cannot be cut.
  double max_bend = in.max_bend;
  bool relaxed = false;
  const auto cost = [&](int i, int remaining, Vec3& normal) {
    const int p = prev[static_cast<std::size_t>(i)], q = next[static_cast<std::size_t>(i)];
    const Vec3 e = OpenMesh::cross(P(i) - P(p), P(q) - P(p));
    if (!(0.5 * e.norm() > min_area)) return std::numeric_limits<double>::infinity();
    if (remaining > 3 && edges.count({std::min(p, q), std::max(p, q)}))
      return std::numeric_limits<double>::infinity();
    normal = e / e.norm();
    double bend = std::max(angle(normal, across[static_cast<std::size_t>(p)]),
                           angle(normal, across[static_cast<std::size_t>(i)]));
    if (remaining == 3) bend = std::max(bend, angle(normal, across[static_cast<std::size_t>(q)]));
    if (bend > max_bend) return std::numeric_limits<double>::infinity();
    // The sharpest corner first (as seed 000 §3.4.2 closes small angles first): the hole
    // closes from its corners inwards and keeps a rounded front; bending and shape break ties.
    const double corner = angle((P(p) - P(i)).normalize_cond(), (P(q) - P(i)).normalize_cond());
    return corner + 0.5 * bend + 0.1 * (1.0 - shape(P(p), P(i), P(q)) / (0.5 * std::sqrt(3.0)));
  };

  int remaining = n;
  int any = 0;  // some vertex still on the polygon
  while (remaining > 3) {
    int best = -1;
    double best_cost = std::numeric_limits<double>::infinity();
    Vec3 best_normal(0, 0, 0);
    int i = any;
    for (int visited = 0; visited < remaining; ++visited, i = next[static_cast<std::size_t>(i)]) {
      if (set_aside[static_cast<std::size_t>(i)]) continue;
      Vec3 normal;
      const double c = cost(i, remaining, normal);
      if (c < best_cost) {
        best_cost = c;
        best = i;
        best_normal = normal;
      }
    }
    if (best < 0 && !relaxed) {
      // Nothing bends little enough: allow anything short of folding back (the intersection
      // checks still hold) until the next ear is cut.
      relaxed = true;
      max_bend = in.fold_bend;
      continue;
    }
    if (best < 0) {
      out.failure = fmt::format(
          "no ear can be cut without crossing the mesh or folding over ({} of {} boundary "
          "vertices left)",
          remaining, n);
      return out;
    }
    const int p = prev[static_cast<std::size_t>(best)], q = next[static_cast<std::size_t>(best)];
    const std::array<int, 3> corners{p, best, q};
    if ((in.crosses_mesh && in.crosses_mesh(corners)) || crosses_cut(corners)) {
      set_aside[static_cast<std::size_t>(best)] = 1;
      continue;
    }
    cut.push_back({P(p), P(best), P(q)});
    cut_ids.push_back(corners);
    out.triangles.push_back(corners);
    edges.insert({std::min(p, q), std::max(p, q)});
    across[static_cast<std::size_t>(p)] = best_normal;
    next[static_cast<std::size_t>(p)] = q;
    prev[static_cast<std::size_t>(q)] = p;
    set_aside[static_cast<std::size_t>(p)] = set_aside[static_cast<std::size_t>(q)] = 0;
    any = p;
    --remaining;
    relaxed = false;
    max_bend = in.max_bend;
  }
  const int a = any, b = next[static_cast<std::size_t>(a)], c = next[static_cast<std::size_t>(b)];
  Vec3 normal;
  max_bend = in.fold_bend;  // the last triangle has no alternative
  const std::array<int, 3> last{a, b, c};
  if (!std::isfinite(cost(b, 3, normal)) || (in.crosses_mesh && in.crosses_mesh(last)) ||
      crosses_cut(last)) {
    out.failure = "the last triangle would cross the mesh or fold over";
    return out;
  }
  out.triangles.push_back(last);
  out.ok = true;
  return out;
}

}  // namespace touchmend::geometry
