#include "server/geometry/liepa_triangulation.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <numbers>
#include <unordered_set>

#include <fmt/format.h>

#include "server/geometry/intersection.h"

namespace touchmend::geometry {
namespace {

// Angles closer than kAngleTie (in the bend measure below, ~1e-9 rad) are equal, so that
// coplanar candidates, whose angles differ only by rounding, are ranked by area as the
// weight intends.
constexpr double kAngleTie = 1e-18;
// Every triangulation of a planar polygon has the same area, so areas that differ only by
// rounding are equal too, and then the triangulation whose worst triangle is best wins (our
// third term: Liepa's weight leaves such ties to chance, which on the straight runs of a
// CAD part's hole picks slivers).
constexpr double kAreaTie = 1e-9;
constexpr double kInfinity = std::numeric_limits<double>::infinity();
// The rising bound's step (ours). Each failed pass costs a solve under the lower bound, one
// that overshoots the optimum weighs the candidates in between: on rocker-arm_xl's 264-vertex
// loop (optimum 62°, lower bound 44.5°) 10° steps take 8.8 ms, 20° 6.9 ms, the exhaustive
// search 29.6 ms; on spot_sml #2 (59 vertices, 24.6° against 67.2°) every step size loses to
// the exhaustive search, hence also LiepaTriangulationOptions::rising_angle_bound_min_vertices.
constexpr double kAngleBoundStepDeg = 20;

//! A measure of the angle between unit normals that grows with the angle on [0, π] and needs
//! no trigonometry (the DP evaluates it O(n^3) times): sin² below 90°, 2 - sin² above. It is
//! accurate near 0, where 1 - cos would lose half the digits.
[[gnu::always_inline]] inline double angle_between(const Vec3& n1, const Vec3& n2) {
  const double s2 = OpenMesh::cross(n1, n2).sqrnorm();
  return OpenMesh::dot(n1, n2) >= 0 ? s2 : 2.0 - s2;
}

[[gnu::always_inline]] inline Vec3 unit_normal(const Vec3& a, const Vec3& b, const Vec3& c,
                                               double& area) {
  Vec3 nrm = OpenMesh::cross(b - a, c - a);
  const double len = nrm.norm();
  area = 0.5 * len;
  return len > 0 ? nrm / len : nrm;
}

//! The next bound of the rising search: a fixed number of degrees more, the last step admitting
//! every candidate. Each step costs a solve; one too high costs the candidates between the
//! optimum and the bound (measured on the 264-vertex loop of rocker-arm_xl: README).
double raised_angle_bound(double bound) {
  const double degrees = bound <= 1
                             ? std::asin(std::sqrt(bound)) * 180 / std::numbers::pi
                             : 180 - std::asin(std::sqrt(2 - bound)) * 180 / std::numbers::pi;
  const double next = degrees + kAngleBoundStepDeg;
  if (next >= 180) return kInfinity;
  const double s = std::sin(next * std::numbers::pi / 180);
  return next <= 90 ? s * s : 2.0 - s * s;
}

}  // namespace

bool MinDihedralTriangulator::Weight::operator<(const Weight& o) const {
  if (std::abs(angle - o.angle) > kAngleTie) return angle < o.angle;
  if (std::abs(area - o.area) > kAreaTie * std::max(area, o.area)) return area < o.area;
  return shape > o.shape;
}

MinDihedralTriangulator::Weight MinDihedralTriangulator::Weight::operator+(const Weight& o) const {
  return {std::max(angle, o.angle), area + o.area, std::min(shape, o.shape)};
}

MinDihedralTriangulator::MinDihedralTriangulator(std::span<const Vec3> loop,
                                                 std::span<const Vec3> opposite,
                                                 std::span<const std::pair<int, int>> blocked,
                                                 const LiepaTriangulationOptions& options)
    : n_(static_cast<int>(loop.size())),
      largest_angle_cos_(options.max_angle_deg < 180
                             ? std::cos(options.max_angle_deg * std::numbers::pi / 180)
                             : -2.0),
      rising_angle_bound_(options.rising_angle_bound &&
                          loop.size() >= options.rising_angle_bound_min_vertices) {
  if (n_ < 3) {
    failure_ = "fewer than 3 boundary vertices";
    return;
  }
  if (loop.size() > options.max_vertices) {
    failure_ = fmt::format(
        "{} boundary vertices exceed the {}-vertex limit of the 3D "
        "minimum-weight triangulation",
        n_, options.max_vertices);
    return;
  }
  loop_.assign(loop.begin(), loop.end());
  const std::size_t N = loop.size();
  blocked_.assign(N * N, 0);
  for (const auto& [a, b] : blocked) {
    if (a < 0 || b < 0 || a >= n_ || b >= n_) continue;
    const int d = std::abs(a - b);
    if (d == 1 || d == n_ - 1) continue;  // a boundary edge is never blocked
    blocked_[at(std::min(a, b), std::max(a, b))] = 1;
  }
  double mean_edge = 0;
  for (int i = 0; i < n_; ++i) mean_edge += (loop[(i + 1) % N] - loop[i]).norm();
  mean_edge /= n_;
  min_area_ = 1e-12 * mean_edge * mean_edge;
  // Normals of the mesh triangles across each boundary edge i -> i+1 (the mesh triangle holds
  // face-edge i+1 -> i).
  boundary_normal_.resize(N);
  // An opposite point on the edge's line (the edge's midpoint: no triangle across, as the
  // split's curve edges) makes the edge free: its normal is zero, and every triangle bends by
  // nothing against it. The cross product is then rounding noise, which normalised would be a
  // random direction (a fold chosen on couplingdown_sharp #2): below a relative bound it
  // counts as zero.
  for (int i = 0; i < n_; ++i) {
    const Vec3& a = loop[(i + 1) % N];
    const Vec3& b = loop[i];
    const Vec3 normal = OpenMesh::cross(b - a, opposite[i] - a);
    const double scale = (b - a).norm() * (opposite[i] - a).norm();
    constexpr double kCollinearSine = 1e-9;
    boundary_normal_[i] =
        normal.norm() > kCollinearSine * scale ? normal / normal.norm() : Vec3(0, 0, 0);
  }
  weight_.assign(N * N, Weight{});
  lambda_.assign(N * N, -1);
  chosen_normal_.assign(N * N, Vec3(0, 0, 0));
  dirty_from_.assign(N, n_);
  words_ = (N + 63) / 64;
  solvable_from_.assign(N * words_, 0);
  solvable_to_.assign(N * words_, 0);
  base_of_forbidden_.assign(N * N, 0);
}

void MinDihedralTriangulator::set_solvable(int i, int k, bool solvable) {
  const auto bit = [](int b) { return std::uint64_t{1} << (b & 63); };
  std::uint64_t& from = solvable_from_[static_cast<std::size_t>(i) * words_ + (k >> 6)];
  std::uint64_t& to = solvable_to_[static_cast<std::size_t>(k) * words_ + (i >> 6)];
  if (solvable) {
    from |= bit(k);
    to |= bit(i);
  } else {
    from &= ~bit(k);
    to &= ~bit(i);
  }
}

double MinDihedralTriangulator::lowest_possible_angle() const {
  double lowest = 0;
  for (int e = 0; e < n_; ++e) {
    const int a = e, b = (e + 1) % n_;
    double best = kInfinity;
    for (int m = 0; m < n_; ++m) {
      if (m == a || m == b) continue;
      // The triangle on boundary edge a -> b with third corner m, oriented like the loop (as
      // the programme orients (i, m, k), i < m < k).
      double area;
      const Vec3 nrm = unit_normal(loop_[a], loop_[b], loop_[m], area);
      if (area <= min_area_) continue;
      best = std::min(best, angle_between(nrm, boundary_normal_[static_cast<std::size_t>(e)]));
    }
    lowest = std::max(lowest, best);
  }
  return lowest;
}

bool MinDihedralTriangulator::is_forbidden(int i, int m, int k) const {
  return forbidden_.count(forbidden_key(i, m, k, n_)) != 0;
}

void MinDihedralTriangulator::mark_dirty(int first, int last) {
  // dirty_from_ is a suffix minimum: stop where an earlier mark already reaches as far.
  for (int i = first; i >= 0 && dirty_from_[static_cast<std::size_t>(i)] > last; --i)
    dirty_from_[static_cast<std::size_t>(i)] = last;
}

void MinDihedralTriangulator::forbid(std::array<int, 3> corners) {
  std::sort(corners.begin(), corners.end());
  if (!failure_.empty() || corners[0] < 0 || corners[2] >= n_) return;
  if (!forbidden_.insert(forbidden_key(corners[0], corners[1], corners[2], n_)).second) return;
  base_of_forbidden_[at(corners[0], corners[2])] = 1;
  mark_dirty(corners[0], corners[2]);
}

void MinDihedralTriangulator::forbid_chord(int a, int b) {
  if (a > b) std::swap(a, b);
  if (!failure_.empty() || a < 0 || b >= n_ || b - a < 2 || b - a == n_ - 1) return;
  if (blocked_[at(a, b)]) return;
  // Every triangle with edge (a, b) is built by interval (a, b) (as its base) or by an
  // interval that has (a, b) as a sub-interval: blocking the interval removes them all.
  blocked_[at(a, b)] = 1;
  mark_dirty(a, b);
}

LiepaTriangulation MinDihedralTriangulator::solve() {
  LiepaTriangulation out;
  if (!failure_.empty()) {
    out.failure = failure_;
    return out;
  }
  // The bound starts at the lowest the optimum can have and rises by kAngleBoundStepDeg until a
  // triangulation exists under it; a later solve (more triangles forbidden) starts from the
  // bound the previous one ended with. Raising it changes every interval: all are solved again.
  if (!solved_once_) {
    angle_bound_ = rising_angle_bound_ ? lowest_possible_angle() : kInfinity;
    if (!(angle_bound_ < kInfinity)) angle_bound_ = kInfinity;
  }
  for (;;) {
    solve_intervals();
    if (lambda_[at(0, n_ - 1)] >= 0 || !(angle_bound_ < kInfinity)) break;
    angle_bound_ = raised_angle_bound(angle_bound_);
    solved_once_ = false;
  }
  solved_once_ = true;
  std::fill(dirty_from_.begin(), dirty_from_.end(), n_);
  if (lambda_[at(0, n_ - 1)] < 0) {
    out.failure = "no valid 3D triangulation (every candidate is degenerate or reuses an edge)";
    return out;
  }
  std::vector<std::pair<int, int>> stack{{0, n_ - 1}};
  while (!stack.empty()) {
    const auto [i, k] = stack.back();
    stack.pop_back();
    if (k - i < 2) continue;
    const int m = lambda_[at(i, k)];
    out.triangles.push_back({i, m, k});
    stack.emplace_back(i, m);
    stack.emplace_back(m, k);
  }
  out.ok = true;
  return out;
}

void MinDihedralTriangulator::solve_intervals() {
  const Weight invalid{kInfinity, kInfinity, 0.0};
  // Solved before: only the intervals around a newly forbidden triangle; otherwise all.
  const auto dirty = [&](int i, int k) {
    return !solved_once_ || k >= dirty_from_[static_cast<std::size_t>(i)];
  };
  for (int i = 0; i + 1 < n_; ++i) {
    weight_[at(i, i + 1)] = Weight{};
    set_solvable(i, i + 1, true);
  }
  for (int len = 2; len < n_; ++len) {
    for (int i = 0; i + len < n_; ++i) {
      const int k = i + len;
      if (!dirty(i, k)) continue;
      ++intervals_solved_;
      Weight best = invalid;
      int best_m = -1;
      Vec3 best_normal(0, 0, 0);
      // Most intervals are the base of no forbidden triangle: no hash lookup per candidate.
      const bool has_forbidden = base_of_forbidden_[at(i, k)] != 0;
      if (blocked_[at(i, k)]) {
        weight_[at(i, k)] = invalid;
        lambda_[at(i, k)] = -1;
        set_solvable(i, k, false);
        continue;
      }
      const auto consider = [&](int m) {
        const Weight& left = weight_[at(i, m)];
        const Weight& right = weight_[at(m, k)];
        // The combined weight's angle is at least the larger of the two parts' and of each
        // dihedral below: once one of them loses to the best so far (or passes the bound),
        // this candidate cannot win (the checks follow in order of cost).
        const double bound = std::min(best.angle, angle_bound_) + kAngleTie;
        if (std::max(left.angle, right.angle) > bound) return;
        if (has_forbidden && is_forbidden(i, m, k)) return;
        if (largest_angle_cos_ > -2 &&
            largest_angle_cos(loop_[i], loop_[m], loop_[k]) < largest_angle_cos_)
          return;
        // Dihedral deviation against the known neighbours across (i, m) and (m, k). First a
        // test on the unnormalised normal c, without the square root and division of
        // normalising it (angle_between(c / |c|, n) > bound, multiplied out by |c|^2): most
        // candidates stop here. The survivors are measured exactly as the weight needs.
        const Vec3& n_im = (m == i + 1) ? boundary_normal_[i] : chosen_normal_[at(i, m)];
        const Vec3& n_mk = (k == m + 1) ? boundary_normal_[m] : chosen_normal_[at(m, k)];
        const Vec3 c = OpenMesh::cross(loop_[m] - loop_[i], loop_[k] - loop_[i]);
        const double c2 = c.sqrnorm();
        const auto bends_past_bound = [&](const Vec3& n) {
          const double crossed = OpenMesh::cross(c, n).sqrnorm();
          return OpenMesh::dot(c, n) >= 0 ? crossed > bound * c2 : 2.0 * c2 - crossed > bound * c2;
        };
        if (bends_past_bound(n_im) || bends_past_bound(n_mk)) return;
        // As unit_normal computes it (the same cross product, norm and division).
        const double length = std::sqrt(c2);
        const double area = 0.5 * length;
        if (area <= min_area_) return;
        const Vec3 nrm = c / length;
        double angle = angle_between(nrm, n_im);
        if (angle > bound) return;
        angle = std::max(angle, angle_between(nrm, n_mk));
        if (angle > bound) return;
        if (i == 0 && k == n_ - 1) {
          angle = std::max(angle, angle_between(nrm, boundary_normal_[n_ - 1]));
          if (angle > bound) return;
        }
        // The weight left + right + this triangle, compared as Weight::operator< does; its
        // shape term (the dearest) is computed only when angle and area tie with the best or
        // the candidate wins.
        Weight w = left + right;
        w.angle = std::max(w.angle, angle);
        w.area += area;
        bool shape_known = false;
        const auto add_shape = [&] {
          if (shape_known) return;
          w.shape = std::min(w.shape, min_angle_sine(loop_[i], loop_[m], loop_[k], 2 * area));
          shape_known = true;
        };
        bool wins;
        if (std::abs(w.angle - best.angle) > kAngleTie) {
          wins = w.angle < best.angle;
        } else if (std::abs(w.area - best.area) > kAreaTie * std::max(w.area, best.area)) {
          wins = w.area < best.area;
        } else {
          add_shape();
          wins = w.shape > best.shape;
        }
        if (!wins) return;
        add_shape();
        best = w;
        best_m = m;
        best_normal = nrm;
      };
      // Only splits m whose both sides are solvable: one word of bits covers 64 of them.
      const std::uint64_t* from = &solvable_from_[static_cast<std::size_t>(i) * words_];
      const std::uint64_t* to = &solvable_to_[static_cast<std::size_t>(k) * words_];
      for (int w = (i + 1) >> 6; w <= (k - 1) >> 6; ++w) {
        std::uint64_t bits = from[w] & to[w];
        if (w == (i + 1) >> 6) bits &= ~std::uint64_t{0} << ((i + 1) & 63);
        if (w == (k - 1) >> 6) bits &= ~std::uint64_t{0} >> (63 - ((k - 1) & 63));
        while (bits != 0) {
          consider(w * 64 + std::countr_zero(bits));
          bits &= bits - 1;
        }
      }
      weight_[at(i, k)] = best;
      lambda_[at(i, k)] = best_m;
      chosen_normal_[at(i, k)] = best_normal;
      set_solvable(i, k, best_m >= 0);
    }
  }
}

LiepaTriangulation triangulate_min_dihedral(std::span<const Vec3> loop,
                                            std::span<const Vec3> opposite,
                                            std::span<const std::pair<int, int>> blocked,
                                            const LiepaTriangulationOptions& options) {
  return MinDihedralTriangulator(loop, opposite, blocked, options).solve();
}

}  // namespace touchmend::geometry
