#pragma once

//! \file liepa_triangulation.h
//! \brief Minimum-weight triangulation of a 3D hole loop (Liepa 2003, after Barequet and
//! Sharir): the fallback for holes that no plane can project (ALGORITHMS.md §6.2).

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <unordered_set>
#include <utility>
#include <vector>

#include "server/geometry/mesh.h"

namespace touchmend::geometry {

struct LiepaTriangulationOptions {
  std::size_t max_vertices = 400;  //!< O(n^3) time, O(n^2) memory: refuse larger loops
  //! Search under a rising bound on the largest dihedral angle (ours): a pass weighs only the
  //! candidate triangles that bend by at most the bound, which starts at a lower bound of the
  //! optimum's largest bend and rises until a pass finds a triangulation. That one is the
  //! exhaustive search's: the optimum bends no more than it, so none of the optimum's
  //! triangles (nor a better one) was left out. Off: every candidate is weighed (the reference
  //! the tests compare against).
  bool rising_angle_bound = true;
  //! The rising bound is used on loops of at least this many vertices: on smaller ones a
  //! failed pass costs about what the bound saves (README, "Benchmarks").
  std::size_t rising_angle_bound_min_vertices = 64;
  //! Triangles with an angle above this (degrees) are not used, as if forbidden (ours: a region
  //! of the crease split has free curve edges, across which the dihedral weight sees nothing,
  //! and there the smallest area picks a needle that lies along the rim; fandisk_sharp #1's
  //! 168° cap). 180: every triangle may be used.
  double max_angle_deg = 180;
};

//! Key of triangle (i, m, k), i < m < k, of an n-vertex loop (the forbidden triangles of
//! MinDihedralTriangulator, the fill's verdicts on them).
inline std::uint64_t forbidden_key(int i, int m, int k, int n) {
  const auto N = static_cast<std::uint64_t>(n);
  return (static_cast<std::uint64_t>(i) * N + static_cast<std::uint64_t>(m)) * N +
         static_cast<std::uint64_t>(k);
}

//! The triangle (i, m, k) whose forbidden_key over an \p n-vertex loop is \p key.
inline std::array<int, 3> forbidden_corners(std::uint64_t key, int n) {
  const auto N = static_cast<std::uint64_t>(n);
  return {static_cast<int>(key / (N * N)), static_cast<int>(key / N % N),
          static_cast<int>(key % N)};
}

struct LiepaTriangulation {
  bool ok = false;
  std::string failure;
  std::vector<std::array<int, 3>> triangles;  //!< indices into the loop, oriented like it
};

//! Triangulates \p loop (hole on the left of i -> i+1) minimising, lexicographically, the
//! largest dihedral angle against already-known neighbours and then the total area.
//! \param opposite for boundary edge i -> i+1 the third vertex of the mesh triangle on the
//!        other side (NaN-free; use the edge midpoint if there is none)
//! \param blocked undirected index pairs already joined by a mesh edge outside the hole
LiepaTriangulation triangulate_min_dihedral(std::span<const Vec3> loop,
                                            std::span<const Vec3> opposite,
                                            std::span<const std::pair<int, int>> blocked,
                                            const LiepaTriangulationOptions& options = {});

//! triangulate_min_dihedral for a sequence of solves that differ only by triangles forbidden
//! in between (the fill's rounds that forbid what crossed the mesh). The interval tables are
//! kept: the best triangulation of sub-polygon (i, k) depends only on the candidates inside
//! it, so forbidding triangle (a, b, c) changes only the intervals i <= a, c <= k, and only
//! those are solved again (the same result as solving from scratch, at a fraction of the
//! O(n^3) cost when the forbidden triangles do not span the loop).
class MinDihedralTriangulator {
 public:
  MinDihedralTriangulator(std::span<const Vec3> loop, std::span<const Vec3> opposite,
                          std::span<const std::pair<int, int>> blocked,
                          const LiepaTriangulationOptions& options = {});

  //! The best triangulation that uses no forbidden triangle.
  LiepaTriangulation solve();
  //! Forbids the triangle on these three loop indices (any order) for the next solve.
  void forbid(std::array<int, 3> corners);
  //! Forbids the chord between loop indices \p a and \p b (not a boundary edge): no triangle
  //! of the next solve has it as an edge.
  void forbid_chord(int a, int b);
  //! Intervals (i, k) solved so far, over all solves (how much work the tables saved).
  std::size_t intervals_solved() const { return intervals_solved_; }

 private:
  struct Weight {
    double angle = 0;  //!< largest dihedral deviation (angle_between's measure)
    double area = 0;
    double shape = 1;  //!< smallest triangle angle, as min_angle_sine (larger is better)
    bool operator<(const Weight& o) const;
    Weight operator+(const Weight& o) const;
  };
  std::size_t at(int i, int k) const {
    return static_cast<std::size_t>(i) * static_cast<std::size_t>(n_) + static_cast<std::size_t>(k);
  }
  bool is_forbidden(int i, int m, int k) const;
  //! The dynamic programme over the intervals still to solve, admitting only candidates that
  //! bend by at most angle_bound_.
  void solve_intervals();
  //! A lower bound of the optimum's largest dihedral deviation: the triangle on each boundary
  //! edge bends against the mesh triangle across that edge at least as much as the triangle
  //! with the best third corner would, so the largest of those minima is a bound.
  double lowest_possible_angle() const;
  //! Interval (i, k) has a triangulation (under the bound): kept as bits so that the candidate
  //! loop visits only splits m whose two sides both have one.
  void set_solvable(int i, int k, bool solvable);
  //! Every interval (i, k) with i <= first and k >= last must be solved again.
  void mark_dirty(int first, int last);

  int n_ = 0;
  std::string failure_;
  std::vector<Vec3> loop_;
  std::vector<Vec3> boundary_normal_;  //!< of the mesh triangle across boundary edge i -> i+1
  std::vector<char> blocked_;          //!< n x n: pairs joined by a mesh edge outside the hole
  double min_area_ = 0;
  double largest_angle_cos_ = -2;  //!< triangles whose largest angle's cos is below are not used
  bool rising_angle_bound_ = true;
  double angle_bound_ = 0;  //!< candidates bending more than this are not weighed
  std::unordered_set<std::uint64_t> forbidden_;
  //! n x n: interval (i, k) is the base of a forbidden triangle (the programme weighs triangle
  //! (a, b, c), a < b < c, only in interval (a, c)), so only those look up forbidden_.
  std::vector<char> base_of_forbidden_;
  //! Per i: the smallest k of a triangle forbidden since the last solve whose first corner is
  //! >= i (suffix minimum): interval (i, k) must be solved again iff k >= dirty_from_[i].
  std::vector<int> dirty_from_;
  bool solved_once_ = false;
  std::vector<Weight> weight_;
  std::vector<int> lambda_;
  //! Normal of the triangle chosen for interval (i, k): the neighbour across edge (i, k).
  std::vector<Vec3> chosen_normal_;
  std::size_t words_ = 0;  //!< 64-bit words per row of the bit sets below
  //! Row i, bit k: interval (i, k) is solvable; row k, bit i of the second: the same, by column.
  std::vector<std::uint64_t> solvable_from_, solvable_to_;
  std::size_t intervals_solved_ = 0;
};

}  // namespace touchmend::geometry
