#include "server/geometry/planar_triangulation.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <functional>
#include <limits>
#include <numeric>

#include <Eigen/Geometry>

#include "server/geometry/triangulation_front.h"

namespace touchmend::geometry {
namespace {

using detail::TriangulationFront;

//! Point p inside the closed triangle (a, b, c) (counter-clockwise), with a small tolerance.
bool in_triangle(const Point2& a, const Point2& b, const Point2& c, const Point2& p, double eps) {
  return orient2d(a, b, p) >= -eps && orient2d(b, c, p) >= -eps && orient2d(c, a, p) >= -eps;
}

//! A uniform grid over the polygon for Algorithm II's local questions (which points are near an
//! edge, which front edges and points lie in a triangle's box), so that each triangle costs what
//! its neighbourhood costs instead of a pass over the whole front. Points are filed once; front
//! edges are filed when they appear and dropped lazily (the caller checks they are still on the
//! front). It answers exactly what the full scans would.
class PlanarGrid {
 public:
  PlanarGrid(std::span<const Point2> points, double cell_hint) {
    Eigen::AlignedBox2d box;
    for (const Point2& p : points) box.extend(p);
    origin_ = box.min();
    const Eigen::Vector2d size = box.sizes();
    // About one cell per point at most, and no thinner than the typical edge.
    const double area = std::max(size.x() * size.y(), 1e-300);
    cell_ = std::max({cell_hint, std::sqrt(area / static_cast<double>(points.size())),
                      size.x() / 4000, size.y() / 4000, 1e-300});
    nx_ = std::clamp(static_cast<int>(size.x() / cell_) + 1, 1, 4096);
    ny_ = std::clamp(static_cast<int>(size.y() / cell_) + 1, 1, 4096);
    points_in_.resize(static_cast<std::size_t>(nx_) * static_cast<std::size_t>(ny_));
    edges_in_.resize(points_in_.size());
    for (std::size_t i = 0; i < points.size(); ++i)
      points_in_[cell(points[i])].push_back(static_cast<int>(i));
  }
  void add_edge(int a, int b, const Point2& pa, const Point2& pb) {
    for_each_cell(pa.cwiseMin(pb), pa.cwiseMax(pb),
                  [&](std::size_t c) { edges_in_[c].emplace_back(a, b); });
  }
  //! visit(point index) for the points in the cells meeting [lo, hi].
  template <typename Visit>
  void points_in_box(const Point2& lo, const Point2& hi, Visit&& visit) const {
    for_each_cell(lo, hi, [&](std::size_t c) {
      for (const int i : points_in_[c]) visit(i);
    });
  }
  //! visit(a, b) for the edges filed in the cells meeting [lo, hi] (an edge may come twice).
  template <typename Visit>
  void edges_in_box(const Point2& lo, const Point2& hi, Visit&& visit) const {
    for_each_cell(lo, hi, [&](std::size_t c) {
      for (const auto& [a, b] : edges_in_[c]) visit(a, b);
    });
  }
  template <typename Visit>
  void for_each_cell(const Point2& lo, const Point2& hi, Visit&& visit) const {
    const auto [x0, y0] = cell_xy(lo);
    const auto [x1, y1] = cell_xy(hi);
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) visit(index(x, y));
  }
  //! visit(point index) for the points of the cells at Chebyshev distance \p ring from the
  //! cell of \p centre; false once the ring lies wholly outside the grid.
  template <typename Visit>
  bool ring(const Point2& centre, int ring, Visit&& visit) const {
    const auto [cx, cy] = cell_xy(centre);
    if (cx - ring < 0 && cy - ring < 0 && cx + ring >= nx_ && cy + ring >= ny_) return false;
    for (int y = cy - ring; y <= cy + ring; ++y) {
      if (y < 0 || y >= ny_) continue;
      const bool edge_row = y == cy - ring || y == cy + ring;
      for (int x = cx - ring; x <= cx + ring; x += (edge_row || ring == 0) ? 1 : 2 * ring) {
        if (x < 0 || x >= nx_) continue;
        for (const int i : points_in_[index(x, y)]) visit(i);
      }
    }
    return true;
  }
  //! No point of a ring beyond \p ring lies nearer to \p centre than this.
  double ring_clearance(const Point2& centre, int ring) const {
    const auto [cx, cy] = cell_xy(centre);
    const double fx = (centre.x() - origin_.x()) / cell_ - cx;
    const double fy = (centre.y() - origin_.y()) / cell_ - cy;
    const double to_edge = std::min({fx, 1 - fx, fy, 1 - fy});
    return (ring + std::max(0.0, to_edge)) * cell_;
  }

 private:
  std::pair<int, int> cell_xy(const Point2& p) const {
    const double fx = (p.x() - origin_.x()) / cell_, fy = (p.y() - origin_.y()) / cell_;
    return {std::clamp(static_cast<int>(std::floor(fx)), 0, nx_ - 1),
            std::clamp(static_cast<int>(std::floor(fy)), 0, ny_ - 1)};
  }
  std::size_t index(int x, int y) const {
    return static_cast<std::size_t>(y) * static_cast<std::size_t>(nx_) +
           static_cast<std::size_t>(x);
  }
  std::size_t cell(const Point2& p) const {
    const auto [x, y] = cell_xy(p);
    return index(x, y);
  }

  Point2 origin_{0, 0};
  double cell_ = 1;
  int nx_ = 1, ny_ = 1;
  std::vector<std::vector<int>> points_in_;
  std::vector<std::vector<std::pair<int, int>>> edges_in_;
};

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
  PlanarGrid grid(polygon, mean_edge);
  {
    auto edges = front.edges();
    std::sort(edges.begin(), edges.end());  // deterministic
    queue.assign(edges.begin(), edges.end());
    for (const auto& [x, y] : edges) grid.add_edge(x, y, P(x), P(y));
  }
  // Whether segment (a, b) properly crosses a front edge that does not share an endpoint.
  const auto crosses_front_near = [&](int a, int b) {
    bool crossing = false;
    grid.edges_in_box(P(a).cwiseMin(P(b)), P(a).cwiseMax(P(b)), [&](int x, int y) {
      if (crossing || x == a || x == b || y == a || y == b || !front.has_front_edge(x, y)) return;
      crossing = segments_cross(P(a), P(b), P(x), P(y), true);
    });
    return crossing;
  };
  const auto contains_active_near = [&](int a, int b, int c) {
    bool inside = false;
    const Point2 lo = P(a).cwiseMin(P(b)).cwiseMin(P(c)), hi = P(a).cwiseMax(P(b)).cwiseMax(P(c));
    grid.points_in_box(lo, hi, [&](int v) {
      if (inside || v == a || v == b || v == c || !front.is_active(v)) return;
      inside = in_triangle(P(a), P(b), P(c), P(v), contain_eps);
    });
    return inside;
  };
  std::size_t stalled = 0;
  // Candidates by (sum of squared distances, index), smallest first: the order of the full scan.
  using Candidate = std::pair<double, int>;
  std::vector<Candidate> heap;
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
    // The thesis' criterion: the point with the minimum sum of squared distances to a and b,
    // 2|c - m|² + |ab|²/2 with m the edge's middle, so the points come ring by ring around m and
    // a ring's points are tried once no farther ring can hold a nearer one.
    const Point2 m = 0.5 * (P(a) + P(b));
    const double half = 0.5 * (P(a) - P(b)).squaredNorm();
    heap.clear();
    bool created = false;
    for (int r = 0; !created; ++r) {
      const bool more = grid.ring(m, r, [&](int c) {
        if (c == a || c == b || !front.is_active(c)) return;
        if (orient2d(P(a), P(b), P(c)) <= area_eps) return;  // must lie inside the hole
        heap.emplace_back((P(c) - P(a)).squaredNorm() + (P(c) - P(b)).squaredNorm(), c);
        std::push_heap(heap.begin(), heap.end(), std::greater<>());
      });
      const double clear = grid.ring_clearance(m, r);
      const double bound =
          more ? 2 * clear * clear + half : std::numeric_limits<double>::infinity();
      while (!heap.empty() && heap.front().first < bound && !created) {
        std::pop_heap(heap.begin(), heap.end(), std::greater<>());
        const int c = heap.back().second;
        heap.pop_back();
        if (!front.can_add_face(a, b, c)) continue;
        if (!front.has_front_edge(b, c) && crosses_front_near(b, c)) continue;
        if (!front.has_front_edge(c, a) && crosses_front_near(c, a)) continue;
        if (contains_active_near(a, b, c)) continue;
        for (const auto& e : front.add_face(a, b, c)) {
          queue.push_back(e);
          grid.add_edge(e.first, e.second, P(e.first), P(e.second));
        }
        created = true;
      }
      if (!more) break;
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
