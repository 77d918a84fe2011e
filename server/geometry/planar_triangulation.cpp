#include "server/geometry/planar_triangulation.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <numeric>

#include "server/geometry/triangulation_front.h"

namespace touchmend::geometry {
namespace {

using detail::TriangulationFront;

//! Point p inside the closed triangle (a, b, c) (counter-clockwise), with a small tolerance.
bool in_triangle(const Point2& a, const Point2& b, const Point2& c, const Point2& p, double eps) {
  return orient2d(a, b, p) >= -eps && orient2d(b, c, p) >= -eps && orient2d(c, a, p) >= -eps;
}

}  // namespace

double interior_angle(const Point2& a, const Point2& b, const Point2& c) {
  const Point2 u = c - b;  // towards the successor
  const Point2 w = a - b;  // towards the predecessor
  double theta = std::atan2(u.x() * w.y() - u.y() * w.x(), u.dot(w));
  if (theta < 0) theta += 2 * std::numbers::pi;
  return theta;
}

PlanarTriangulation triangulate_planar(std::span<const Point2> polygon,
                                       std::span<const std::pair<int, int>> blocked,
                                       const PlanarTriangulationOptions& options) {
  PlanarTriangulation out;
  const int n = static_cast<int>(polygon.size());
  if (n < 3) {
    out.failure = "fewer than 3 boundary vertices";
    return out;
  }
  double mean_edge = 0;
  for (int i = 0; i < n; ++i) mean_edge += (polygon[(i + 1) % n] - polygon[i]).norm();
  mean_edge /= n;
  // Areas below this are degenerate; containment uses a length-scaled tolerance.
  const double area_eps = 1e-10 * mean_edge * mean_edge;
  const double contain_eps = 1e-12 * mean_edge * mean_edge;

  std::vector<int> loop(static_cast<std::size_t>(n));
  std::iota(loop.begin(), loop.end(), 0);
  TriangulationFront front(static_cast<std::size_t>(n), loop, blocked);
  const auto P = [&](int i) -> const Point2& { return polygon[static_cast<std::size_t>(i)]; };

  // Whether segment (a, b) properly crosses a front edge that does not share an endpoint.
  auto crosses_front = [&](int a, int b, const std::vector<std::pair<int, int>>& edges) {
    for (const auto& [x, y] : edges) {
      if (x == a || x == b || y == a || y == b) continue;
      if (segments_cross(P(a), P(b), P(x), P(y), true)) return true;
    }
    return false;
  };
  auto contains_active = [&](int a, int b, int c, const std::vector<int>& active) {
    for (int v : active) {
      if (v == a || v == b || v == c) continue;
      if (in_triangle(P(a), P(b), P(c), P(v), contain_eps)) return true;
    }
    return false;
  };

  // --- Seed 000 §3.4.2: close consecutive boundary angles below 5π/9 ---------------------
  // The front is still one simple cycle here, kept as a doubly linked list.
  if (options.close_small_angles && n > 3) {
    std::vector<int> next(static_cast<std::size_t>(n)), prev(static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i) {
      next[i] = (i + 1) % n;
      prev[i] = (i + n - 1) % n;
    }
    int remaining = n;
    int j = 0;
    int failures_in_a_row = 0;
    while (remaining > 3 && failures_in_a_row < remaining) {
      const int i = prev[j], k = next[j];
      const double theta = interior_angle(P(i), P(j), P(k));
      bool clipped = false;
      if (theta < options.close_angle && orient2d(P(i), P(j), P(k)) > area_eps &&
          front.can_add_face(i, j, k)) {
        // The front is the cycle next[]: walk it for the ear tests (no allocation).
        bool blocked_ear = false;
        for (int a = next[k]; a != i && !blocked_ear; a = next[a]) {
          const int b = next[a];
          if (in_triangle(P(i), P(j), P(k), P(a), contain_eps))
            blocked_ear = true;
          else if (a != i && b != i && a != k && b != k &&
                   segments_cross(P(i), P(k), P(a), P(b), true))
            blocked_ear = true;
        }
        if (!blocked_ear) {
          front.add_face(i, j, k);
          next[i] = k;
          prev[k] = i;
          --remaining;
          ++out.angles_closed;
          clipped = true;
          failures_in_a_row = 0;
          j = k;  // the angles at i and k changed; continue from k
        }
      }
      if (!clipped) {
        ++failures_in_a_row;
        j = next[j];
      }
    }
    if (remaining == 3) {
      const int a = j, b = next[j], c = next[next[j]];
      if (front.can_add_face(a, b, c) && orient2d(P(a), P(b), P(c)) > area_eps) {
        front.add_face(a, b, c);
        ++out.angles_closed;
      }
    }
  }

  // --- Seed 000 §3.4.3, Algorithm II: for each front edge the point with the minimum sum of
  // squared distances to its ends that forms a valid triangle (ALGORITHMS.md §2.2).
  std::deque<std::pair<int, int>> queue;
  {
    auto edges = front.edges();
    std::sort(edges.begin(), edges.end());  // deterministic
    queue.assign(edges.begin(), edges.end());
  }
  std::size_t stalled = 0;
  std::vector<std::pair<double, int>> candidates;
  while (!front.empty()) {
    if (queue.empty() || stalled > front.size() + 1) {
      out.failure = "Algorithm II stalled: no valid triangle for any remaining boundary edge";
      out.triangles = front.faces();
      out.ok = false;
      return out;
    }
    const auto [a, b] = queue.front();
    queue.pop_front();
    if (!front.has_front_edge(a, b)) continue;
    const std::vector<int> active = front.active_vertices();
    candidates.clear();
    for (int c : active) {
      if (c == a || c == b) continue;
      if (orient2d(P(a), P(b), P(c)) <= area_eps) continue;  // must lie inside the hole
      candidates.emplace_back((P(c) - P(a)).squaredNorm() + (P(c) - P(b)).squaredNorm(), c);
    }
    // The thesis' criterion: the point with the minimum sum of squared distances. Usually one
    // of the first few passes, so only the 16 best are sorted before the rest.
    const std::size_t head = std::min<std::size_t>(16, candidates.size());
    std::partial_sort(candidates.begin(), candidates.begin() + static_cast<std::ptrdiff_t>(head),
                      candidates.end());
    bool created = false;
    const auto edges = front.edges();
    for (std::size_t ci = 0; ci < candidates.size() && !created; ++ci) {
      if (ci == head)
        std::sort(candidates.begin() + static_cast<std::ptrdiff_t>(head), candidates.end());
      const int c = candidates[ci].second;
      if (!front.can_add_face(a, b, c)) continue;
      if (!front.has_front_edge(b, c) && crosses_front(b, c, edges)) continue;
      if (!front.has_front_edge(c, a) && crosses_front(c, a, edges)) continue;
      if (contains_active(a, b, c, active)) continue;
      for (const auto& e : front.add_face(a, b, c)) queue.push_back(e);
      created = true;
    }
    if (created) {
      stalled = 0;
    } else {
      queue.push_back({a, b});
      ++stalled;
    }
  }
  out.triangles = front.faces();
  out.ok = true;
  return out;
}

}  // namespace touchmend::geometry
