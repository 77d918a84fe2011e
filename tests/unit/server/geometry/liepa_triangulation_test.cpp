#include "server/geometry/liepa_triangulation.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>

#include <gtest/gtest.h>

namespace touchmend::geometry {
namespace {

TEST(MinimumDihedralTriangulation, PlanarLoopGivesFlatTriangulation) {
  std::vector<Vec3> loop, opposite;
  const int n = 12;
  for (int i = 0; i < n; ++i)
    loop.emplace_back(std::cos(2 * std::numbers::pi * i / n),
                      std::sin(2 * std::numbers::pi * i / n), 0);
  for (int i = 0; i < n; ++i) {
    const Vec3 mid = 0.5 * (loop[i] + loop[(i + 1) % n]);
    opposite.push_back(mid * 1.5);  // coplanar neighbours outside the loop
  }
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

TEST(MinimumDihedralTriangulation, ForbiddenTrianglesAreNeverUsed) {
  // A planar 10-gon: forbid every triangle of the first solution and solve again; the second
  // solution is a different full triangulation that uses none of them.
  std::vector<Vec3> loop, opposite;
  const int n = 10;
  for (int i = 0; i < n; ++i)
    loop.emplace_back(std::cos(2 * std::numbers::pi * i / n),
                      std::sin(2 * std::numbers::pi * i / n), 0);
  for (int i = 0; i < n; ++i) opposite.push_back(0.5 * (loop[i] + loop[(i + 1) % n]) * 1.5);
  const auto first = triangulate_min_dihedral(loop, opposite, {});
  ASSERT_TRUE(first.ok) << first.failure;
  std::unordered_set<std::uint64_t> forbidden;
  for (auto t : first.triangles) {
    std::sort(t.begin(), t.end());
    forbidden.insert(forbidden_key(t[0], t[1], t[2], n));
  }
  LiepaTriangulationOptions options;
  options.forbidden = &forbidden;
  const auto second = triangulate_min_dihedral(loop, opposite, {}, options);
  ASSERT_TRUE(second.ok) << second.failure;
  EXPECT_EQ(second.triangles.size(), static_cast<std::size_t>(n - 2));
  for (auto t : second.triangles) {
    std::sort(t.begin(), t.end());
    EXPECT_EQ(forbidden.count(forbidden_key(t[0], t[1], t[2], n)), 0u);
  }
}

}  // namespace
}  // namespace touchmend::geometry
