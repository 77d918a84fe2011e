#include "server/geometry/liepa_triangulation.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <random>

#include <gtest/gtest.h>

#include "server/geometry/intersection.h"

namespace touchmend::geometry {
namespace {

//! A planar regular n-gon in z = 0, its neighbours coplanar outside it (opposite corners at
//! 1.5x the edge midpoints).
void planar_loop(int n, std::vector<Vec3>& loop, std::vector<Vec3>& opposite) {
  for (int i = 0; i < n; ++i)
    loop.emplace_back(std::cos(2 * std::numbers::pi * i / n),
                      std::sin(2 * std::numbers::pi * i / n), 0);
  for (int i = 0; i < n; ++i) opposite.push_back(0.5 * (loop[i] + loop[(i + 1) % n]) * 1.5);
}

TEST(MinimumDihedralTriangulation, PlanarLoopGivesFlatTriangulation) {
  std::vector<Vec3> loop, opposite;
  const int n = 12;
  planar_loop(n, loop, opposite);
  const auto t = triangulate_min_dihedral(loop, opposite, {});
  ASSERT_TRUE(t.ok) << t.failure;
  EXPECT_EQ(t.triangles.size(), static_cast<std::size_t>(n - 2));
  for (const auto& tri : t.triangles) {
    const Vec3 nrm = OpenMesh::cross(loop[tri[1]] - loop[tri[0]], loop[tri[2]] - loop[tri[0]]);
    EXPECT_GT(nrm[2], 0);  // oriented like the loop (counter-clockwise seen from +z)
  }
}

TEST(MinimumDihedralTriangulation, SaddleLoopIsAValidDisk) {
  std::vector<Vec3> loop, opposite;
  const int n = 16;
  for (int i = 0; i < n; ++i) {
    const double a = 2 * std::numbers::pi * i / n;
    loop.emplace_back(std::cos(a), std::sin(a), 0.5 * std::cos(2 * a));
  }
  for (int i = 0; i < n; ++i) opposite.push_back(0.5 * (loop[i] + loop[(i + 1) % n]) * 1.5);
  const auto t = triangulate_min_dihedral(loop, opposite, {});
  ASSERT_TRUE(t.ok) << t.failure;
  EXPECT_EQ(t.triangles.size(), static_cast<std::size_t>(n - 2));
  std::map<std::pair<int, int>, int> directed;
  for (const auto& tri : t.triangles)
    for (int k = 0; k < 3; ++k) ++directed[{tri[k], tri[(k + 1) % 3]}];
  for (int i = 0; i < n; ++i)
    EXPECT_EQ(directed[std::make_pair(i, (i + 1) % n)], 1);  // every boundary edge once
  for (const auto& [e, c] : directed) {
    EXPECT_EQ(c, 1);
    if (e.second != (e.first + 1) % n) {
      EXPECT_EQ(directed.count({e.second, e.first}), 1u);
    }
  }
}

TEST(MinimumDihedralTriangulation, RefusesOversizedAndBlockedLoops) {
  std::vector<Vec3> loop, opposite;
  for (int i = 0; i < 20; ++i) {
    loop.emplace_back(std::cos(i * 0.3), std::sin(i * 0.3), 0);
    opposite.emplace_back(0, 0, -1);
  }
  LiepaTriangulationOptions small;
  small.max_vertices = 10;
  EXPECT_FALSE(triangulate_min_dihedral(loop, opposite, {}, small).ok);
  const std::vector<Vec3> quad = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  const std::vector<Vec3> opp(4, Vec3(0.5, 0.5, -1));
  const std::vector<std::pair<int, int>> both = {{0, 2}, {1, 3}};
  EXPECT_FALSE(triangulate_min_dihedral(quad, opp, both).ok);
  const std::vector<std::pair<int, int>> one = {{0, 2}};
  const auto t = triangulate_min_dihedral(quad, opp, one);
  ASSERT_TRUE(t.ok);
  for (const auto& tri : t.triangles) {
    const bool has0 = tri[0] == 0 || tri[1] == 0 || tri[2] == 0;
    const bool has2 = tri[0] == 2 || tri[1] == 2 || tri[2] == 2;
    EXPECT_FALSE(has0 && has2);
  }
}

//! The reference for the kept tables: a new triangulator told the whole forbidden set (and
//! forbidden chords) before its first solve, which solves every interval.
LiepaTriangulation solve_from_scratch(const std::vector<Vec3>& loop,
                                      const std::vector<Vec3>& opposite,
                                      const LiepaTriangulationOptions& options,
                                      const std::unordered_set<std::uint64_t>& forbidden,
                                      const std::vector<std::pair<int, int>>& chords = {}) {
  MinDihedralTriangulator fresh(loop, opposite, {}, options);
  for (const std::uint64_t key : forbidden)
    fresh.forbid(forbidden_corners(key, static_cast<int>(loop.size())));
  for (const auto& [a, b] : chords) fresh.forbid_chord(a, b);
  return fresh.solve();
}

TEST(MinimumDihedralTriangulation, ForbiddenTrianglesAreNeverUsed) {
  // A planar 10-gon: forbid every triangle of the first solution and solve again; the second
  // solution is a different full triangulation that uses none of them.
  std::vector<Vec3> loop, opposite;
  const int n = 10;
  planar_loop(n, loop, opposite);
  const auto first = triangulate_min_dihedral(loop, opposite, {});
  ASSERT_TRUE(first.ok) << first.failure;
  std::unordered_set<std::uint64_t> forbidden;
  for (auto t : first.triangles) {
    std::sort(t.begin(), t.end());
    forbidden.insert(forbidden_key(t[0], t[1], t[2], n));
  }
  const auto second = solve_from_scratch(loop, opposite, {}, forbidden);
  ASSERT_TRUE(second.ok) << second.failure;
  EXPECT_EQ(second.triangles.size(), static_cast<std::size_t>(n - 2));
  for (auto t : second.triangles) {
    std::sort(t.begin(), t.end());
    EXPECT_EQ(forbidden.count(forbidden_key(t[0], t[1], t[2], n)), 0u);
  }
}

//! A bumpy 3D loop (no two candidates tie), for the incremental solves.
void bumpy_loop(int n, std::vector<Vec3>& loop, std::vector<Vec3>& opposite) {
  for (int i = 0; i < n; ++i) {
    const double a = 2 * std::numbers::pi * i / n;
    loop.emplace_back(std::cos(a) * (1 + 0.1 * std::sin(3 * a)), std::sin(a),
                      0.3 * std::cos(2 * a) + 0.05 * std::sin(5 * a));
  }
  for (int i = 0; i < n; ++i)
    opposite.push_back(0.5 * (loop[i] + loop[(i + 1) % n]) * 1.5 + Vec3(0, 0, -0.1));
}

TEST(MinimumDihedralTriangulation, IncrementalSolvesMatchSolvingFromScratch) {
  // Rounds that forbid a few triangles each (as the fill's avoiding rounds do): every solve of
  // the kept tables equals a solve from scratch with the same forbidden set, and the later
  // solves redo only part of the intervals.
  std::vector<Vec3> loop, opposite;
  const int n = 24;
  bumpy_loop(n, loop, opposite);
  MinDihedralTriangulator solver(loop, opposite, {});
  std::unordered_set<std::uint64_t> forbidden;
  const std::size_t all_intervals = static_cast<std::size_t>((n - 1) * (n - 2) / 2);
  for (int round = 0; round < 6; ++round) {
    const auto kept = solver.solve();
    const auto fresh = solve_from_scratch(loop, opposite, {}, forbidden);
    ASSERT_EQ(kept.ok, fresh.ok) << "round " << round;
    if (!kept.ok) break;
    EXPECT_EQ(kept.triangles, fresh.triangles) << "round " << round;
    if (round == 0) {
      EXPECT_EQ(solver.intervals_solved(), all_intervals);
    }
    // Forbid the solution's smallest-span triangle (a local change).
    auto pick = *std::min_element(kept.triangles.begin(), kept.triangles.end(), [](auto a, auto b) {
      std::sort(a.begin(), a.end());
      std::sort(b.begin(), b.end());
      return a[2] - a[0] < b[2] - b[0];
    });
    solver.forbid(pick);
    std::sort(pick.begin(), pick.end());
    forbidden.insert(forbidden_key(pick[0], pick[1], pick[2], n));
  }
  EXPECT_LT(solver.intervals_solved(), 6 * all_intervals);
}

//! A loop on a wavy surface with a fold (a crease across it, like a hole on a CAD part's edge)
//! and a little deterministic jitter, so the largest bend is neither at the boundary nor tied.
void folded_loop(int n, std::vector<Vec3>& loop, std::vector<Vec3>& opposite) {
  for (int i = 0; i < n; ++i) {
    const double a = 2 * std::numbers::pi * i / n;
    const double x = std::cos(a), y = std::sin(a);
    const double jitter = 0.02 * std::sin(7.3 * i) * std::cos(3.1 * i);
    loop.emplace_back(x + jitter, y, 0.6 * std::abs(x) + 0.1 * std::sin(4 * a) + jitter);
  }
  for (int i = 0; i < n; ++i) {
    const Vec3 mid = 0.5 * (loop[i] + loop[(i + 1) % n]);
    opposite.push_back(Vec3(1.4 * mid[0], 1.4 * mid[1], mid[2] - 0.05));
  }
}

TEST(MinimumDihedralTriangulation, RisingAngleBoundFindsTheExhaustiveOptimum) {
  // The rising bound (forced on small loops here) must return exactly the triangulation the
  // exhaustive search does: on ties (the planar loop), on a saddle, on bumpy and folded loops
  // of several sizes, and with blocked chords.
  LiepaTriangulationOptions exhaustive, rising;
  exhaustive.rising_angle_bound = false;
  rising.rising_angle_bound_min_vertices = 3;
  const auto compare = [&](const std::vector<Vec3>& loop, const std::vector<Vec3>& opposite,
                           const std::vector<std::pair<int, int>>& blocked, const char* what) {
    const auto reference = triangulate_min_dihedral(loop, opposite, blocked, exhaustive);
    const auto bounded = triangulate_min_dihedral(loop, opposite, blocked, rising);
    ASSERT_TRUE(reference.ok) << what << ": " << reference.failure;
    ASSERT_TRUE(bounded.ok) << what << ": " << bounded.failure;
    EXPECT_EQ(bounded.triangles, reference.triangles) << what;
  };
  for (const int n : {5, 12, 40}) {
    std::vector<Vec3> loop, opposite;
    planar_loop(n, loop, opposite);
    compare(loop, opposite, {}, "planar");
  }
  for (const int n : {6, 24, 70}) {
    std::vector<Vec3> loop, opposite;
    bumpy_loop(n, loop, opposite);
    compare(loop, opposite, {}, "bumpy");
    std::vector<Vec3> folded, folded_opposite;
    folded_loop(n, folded, folded_opposite);
    compare(folded, folded_opposite, {}, "folded");
    compare(folded, folded_opposite, {{0, n / 2}, {1, n / 3}, {2, n - 3}}, "folded, blocked");
  }
  // Neighbours folded back over the hole: the best triangulation bends by more than 90°.
  std::vector<Vec3> loop, opposite;
  planar_loop(16, loop, opposite);
  for (auto& o : opposite) o = Vec3(0.3 * o[0], 0.3 * o[1], 0.4);
  compare(loop, opposite, {}, "folded back");
}

//! A loop with random heights and neighbours in random directions (seeded: the same every
//! run), so that the largest bend can be anywhere, also at the edge that closes the loop.
void random_loop(int n, std::mt19937& random, std::vector<Vec3>& loop,
                 std::vector<Vec3>& opposite) {
  const auto uniform = [&random] {  // in [-1, 1], the same on every standard library
    return static_cast<double>(random()) / static_cast<double>(std::mt19937::max()) * 2 - 1;
  };
  for (int i = 0; i < n; ++i) {
    const double a = 2 * std::numbers::pi * (i + 0.3 * uniform()) / n;
    loop.emplace_back(std::cos(a), std::sin(a), 0.4 * uniform());
  }
  for (int i = 0; i < n; ++i) {
    const Vec3 mid = 0.5 * (loop[i] + loop[(i + 1) % n]);
    opposite.push_back(Vec3(1.3 * mid[0], 1.3 * mid[1], mid[2]) +
                       0.3 * Vec3(uniform(), uniform(), uniform()));
  }
}

//! The loop of a trial of the forbidden-round tests: 8 + \p trial vertices, random on even
//! trials, folded on odd ones.
void trial_loop(int trial, std::mt19937& random, std::vector<Vec3>& loop,
                std::vector<Vec3>& opposite) {
  const int n = 8 + trial;
  if (trial % 2 == 0) {
    random_loop(n, random, loop, opposite);
  } else {
    folded_loop(n, loop, opposite);
  }
}

TEST(MinimumDihedralTriangulation, RisingAngleBoundMatchesOnRandomLoops) {
  LiepaTriangulationOptions exhaustive, rising;
  exhaustive.rising_angle_bound = false;
  rising.rising_angle_bound_min_vertices = 3;
  std::mt19937 random(20261124);
  for (int trial = 0; trial < 150; ++trial) {
    std::vector<Vec3> loop, opposite;
    random_loop(4 + trial % 40, random, loop, opposite);
    const auto reference = triangulate_min_dihedral(loop, opposite, {}, exhaustive);
    const auto bounded = triangulate_min_dihedral(loop, opposite, {}, rising);
    ASSERT_EQ(bounded.ok, reference.ok) << "trial " << trial;
    EXPECT_EQ(bounded.triangles, reference.triangles) << "trial " << trial;
  }
}

TEST(MinimumDihedralTriangulation, MaxAngleKeepsNeedlesOutWhereItCan) {
  // Every solution under the bound keeps its triangles' angles within it; without the bound
  // some of these loops do use a wider triangle (so the check can fail).
  const double bound_deg = 150;
  const double bound_cos = std::cos(bound_deg * std::numbers::pi / 180);
  LiepaTriangulationOptions capped;
  capped.max_angle_deg = bound_deg;
  std::mt19937 random(20261125);
  std::size_t wide_unbounded = 0, solved_capped = 0;
  for (int trial = 0; trial < 60; ++trial) {
    std::vector<Vec3> loop, opposite;
    random_loop(5 + trial % 20, random, loop, opposite);
    const auto widest_cos = [&](const LiepaTriangulation& t) {
      double widest = 1;
      for (const auto& tri : t.triangles)
        widest = std::min(widest, largest_angle_cos(loop[tri[0]], loop[tri[1]], loop[tri[2]]));
      return widest;
    };
    const auto free = triangulate_min_dihedral(loop, opposite, {});
    ASSERT_TRUE(free.ok) << "trial " << trial;
    if (widest_cos(free) < bound_cos) ++wide_unbounded;
    const auto bounded = triangulate_min_dihedral(loop, opposite, {}, capped);
    if (!bounded.ok) continue;  // no triangulation within the bound
    ++solved_capped;
    EXPECT_GE(widest_cos(bounded), bound_cos) << "trial " << trial;
  }
  EXPECT_GT(wide_unbounded, 0u);
  EXPECT_GT(solved_capped, 30u);
}

// An edge whose opposite point lies on it (a crease split's curve edge: the region across is
// not known yet) is free: no triangle bends against it. Its cross product is rounding noise,
// which must not count as a direction. The dart below (couplingdown_sharp #2's wall beside
// three corners, every edge free) has two triangulations; the one folded over the notch at
// its reflex corner has more area, and a random normal on the free edges once made it win.
TEST(MinimumDihedralTriangulation, EdgesWithOppositeOnThemAreFree) {
  const std::vector<Vec3> loop{{0.2759, -0.1045, 0.1824},
                               {0.3449, -0.1294, 0.1824},
                               {0.3465, -0.1284, 0.1513},
                               {0.3939, -0.1163, 0.1494}};
  // Reversed so that the wall's outside (+y) sees the loop counter-clockwise; the result
  // must not depend on it.
  for (const bool reversed : {false, true}) {
    std::vector<Vec3> points = loop;
    if (reversed) std::reverse(points.begin(), points.end());
    std::vector<Vec3> opposite;
    for (std::size_t i = 0; i < points.size(); ++i)
      opposite.push_back(0.5 * (points[i] + points[(i + 1) % points.size()]));
    const auto t = triangulate_min_dihedral(points, opposite, {});
    ASSERT_TRUE(t.ok) << t.failure;
    Vec3 newell(0, 0, 0);
    for (std::size_t i = 0; i < points.size(); ++i)
      newell += OpenMesh::cross(points[i], points[(i + 1) % points.size()]);
    for (const auto& tri : t.triangles) {
      const Vec3 n =
          OpenMesh::cross(points[tri[1]] - points[tri[0]], points[tri[2]] - points[tri[0]]);
      EXPECT_GT(OpenMesh::dot(n, newell), 0) << "a folded triangle, reversed " << reversed;
    }
  }
}

TEST(MinimumDihedralTriangulation, RisingAngleBoundSurvivesForbiddenRounds) {
  // Forbidding every triangle of each solution forces the later solves over the bound the
  // earlier ones ended with; every solve of the kept tables must still equal the exhaustive
  // search from scratch.
  std::mt19937 random(7);
  LiepaTriangulationOptions rising;
  rising.rising_angle_bound_min_vertices = 3;
  for (int trial = 0; trial < 30; ++trial) {
    std::vector<Vec3> loop, opposite;
    trial_loop(trial, random, loop, opposite);
    const int n = static_cast<int>(loop.size());
    MinDihedralTriangulator solver(loop, opposite, {}, rising);
    std::unordered_set<std::uint64_t> forbidden;
    LiepaTriangulationOptions scratch;
    scratch.rising_angle_bound = false;
    for (int round = 0; round < 4; ++round) {
      const auto kept = solver.solve();
      const auto fresh = solve_from_scratch(loop, opposite, scratch, forbidden);
      ASSERT_EQ(kept.ok, fresh.ok) << "trial " << trial << " round " << round;
      if (!kept.ok) break;
      EXPECT_EQ(kept.triangles, fresh.triangles) << "trial " << trial << " round " << round;
      for (auto t : kept.triangles) {
        solver.forbid(t);
        std::sort(t.begin(), t.end());
        forbidden.insert(forbidden_key(t[0], t[1], t[2], n));
      }
    }
  }
}

TEST(MinimumDihedralTriangulation, KeptTablesMatchSolvingFromScratchUnderRandomForbids) {
  // Rounds that forbid random triangles and chords, on random and folded loops, with and
  // without the rising bound: every solve of the kept tables (which solves again only the
  // intervals around what was forbidden) equals a solve from scratch.
  std::mt19937 random(11);
  for (int trial = 0; trial < 40; ++trial) {
    std::vector<Vec3> loop, opposite;
    trial_loop(trial, random, loop, opposite);
    const int n = static_cast<int>(loop.size());
    LiepaTriangulationOptions options;
    options.rising_angle_bound_min_vertices = trial % 4 < 2 ? 3 : 1000;
    MinDihedralTriangulator solver(loop, opposite, {}, options);
    std::unordered_set<std::uint64_t> forbidden;
    std::vector<std::pair<int, int>> chords;
    std::uniform_int_distribution<int> corner(0, n - 1);
    for (int round = 0; round < 8; ++round) {
      const auto kept = solver.solve();
      const auto fresh = solve_from_scratch(loop, opposite, options, forbidden, chords);
      ASSERT_EQ(kept.ok, fresh.ok) << "trial " << trial << " round " << round;
      if (!kept.ok) break;
      ASSERT_EQ(kept.triangles, fresh.triangles) << "trial " << trial << " round " << round;
      // One triangle of the solution (as the fill's rounds forbid) and one anywhere.
      std::array<int, 3> used =
          kept.triangles[static_cast<std::size_t>(corner(random)) % kept.triangles.size()];
      std::array<int, 3> any{corner(random), corner(random), corner(random)};
      for (auto t : {used, any}) {
        std::sort(t.begin(), t.end());
        if (t[0] == t[1] || t[1] == t[2]) continue;
        solver.forbid(t);
        forbidden.insert(forbidden_key(t[0], t[1], t[2], n));
      }
      if (round % 3 == 2) {
        const int a = corner(random), b = corner(random);
        solver.forbid_chord(a, b);
        chords.emplace_back(a, b);
      }
    }
  }
}

TEST(MinimumDihedralTriangulation, ForbiddenChordIsNoTrianglesEdge) {
  std::vector<Vec3> loop, opposite;
  const int n = 14;
  bumpy_loop(n, loop, opposite);
  MinDihedralTriangulator solver(loop, opposite, {});
  const auto first = solver.solve();
  ASSERT_TRUE(first.ok) << first.failure;
  // Forbid every chord of the first solution.
  std::vector<std::pair<int, int>> chords;
  for (const auto& t : first.triangles)
    for (int e = 0; e < 3; ++e) {
      const int a = std::min(t[e], t[(e + 1) % 3]), b = std::max(t[e], t[(e + 1) % 3]);
      if (b - a != 1 && b - a != n - 1) chords.emplace_back(a, b);
    }
  ASSERT_FALSE(chords.empty());
  for (const auto& [a, b] : chords) solver.forbid_chord(b, a);  // either order
  solver.forbid_chord(0, 1);                                    // a boundary edge: ignored
  const auto second = solver.solve();
  ASSERT_TRUE(second.ok) << second.failure;
  EXPECT_EQ(second.triangles.size(), static_cast<std::size_t>(n - 2));
  for (const auto& t : second.triangles)
    for (int e = 0; e < 3; ++e) {
      const std::pair<int, int> edge(std::min(t[e], t[(e + 1) % 3]),
                                     std::max(t[e], t[(e + 1) % 3]));
      EXPECT_EQ(std::count(chords.begin(), chords.end(), edge), 0)
          << edge.first << "-" << edge.second;
    }
}

}  // namespace
}  // namespace touchmend::geometry
