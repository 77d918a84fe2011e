#include "server/geometry/planar_triangulation.h"

#include <cmath>
#include <map>
#include <numbers>

#include <gtest/gtest.h>

namespace touchmend::geometry {
namespace {

//! Checks a triangulation of a simple polygon: n-2 counter-clockwise triangles whose areas
//! add up to the polygon's, every polygon edge used once in its own direction, every
//! diagonal used once in each direction.
void expect_valid_triangulation(const std::vector<Point2>& poly, const PlanarTriangulation& t) {
  ASSERT_TRUE(t.ok) << t.failure;
  const int n = static_cast<int>(poly.size());
  EXPECT_EQ(t.triangles.size(), poly.size() - 2);
  double area = 0;
  std::map<std::pair<int, int>, int> directed;
  for (const auto& tri : t.triangles) {
    const double a = 0.5 * orient2d(poly[tri[0]], poly[tri[1]], poly[tri[2]]);
    EXPECT_GT(a, 0);
    area += a;
    for (int k = 0; k < 3; ++k) ++directed[{tri[k], tri[(k + 1) % 3]}];
  }
  EXPECT_NEAR(area, signed_area(poly), 1e-9 * std::abs(signed_area(poly)));
  for (const auto& [e, count] : directed) {
    EXPECT_EQ(count, 1);
    const bool boundary = e.second == (e.first + 1) % n;
    if (!boundary) {
      EXPECT_EQ(directed.count({e.second, e.first}), 1u) << e.first << "-" << e.second;
    }
  }
  for (int i = 0; i < n; ++i) EXPECT_EQ(directed.count({i, (i + 1) % n}), 1u);
}

TEST(InteriorAngle, MeasuresInsideTheHole) {
  EXPECT_NEAR(interior_angle({0, 0}, {1, 0}, {1, 1}), std::numbers::pi / 2, 1e-12);
  EXPECT_NEAR(interior_angle({0, 0}, {1, 0}, {1, -1}), 3 * std::numbers::pi / 2, 1e-12);
  EXPECT_NEAR(interior_angle({0, 0}, {1, 0}, {2, 0}), std::numbers::pi, 1e-12);
}

TEST(PlanarTriangulation, Square) {
  const std::vector<Point2> p = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  const auto t = triangulate_planar(p, {});
  expect_valid_triangulation(p, t);
  EXPECT_GE(t.angles_closed, 1u);  // 90° < 5π/9: the first corner is closed as an angle
}

TEST(PlanarTriangulation, ConcaveCombAndRegularPolygon) {
  std::vector<Point2> comb = {{0, 0}, {10, 0}, {10, 3}};
  for (int i = 9; i >= 1; --i) {
    comb.push_back({i + 0.5, 1});
    comb.push_back({static_cast<double>(i), 3});
  }
  comb.push_back({0, 3});
  expect_valid_triangulation(comb, triangulate_planar(comb, {}));
  std::vector<Point2> circle;
  for (int i = 0; i < 200; ++i)
    circle.push_back(
        {std::cos(2 * std::numbers::pi * i / 200), std::sin(2 * std::numbers::pi * i / 200)});
  const auto t = triangulate_planar(circle, {});
  expect_valid_triangulation(circle, t);
  EXPECT_EQ(t.angles_closed, 0u);  // every corner is wider than 5π/9
}

TEST(PlanarTriangulation, CollinearRunsAndDisabledAngleClosing) {
  const std::vector<Point2> p = {{0, 0}, {1, 0}, {2, 0}, {3, 0}, {3, 1}, {2, 1}, {1, 1}, {0, 1}};
  expect_valid_triangulation(p, triangulate_planar(p, {}));
  PlanarTriangulationOptions o;
  o.close_small_angles = false;
  const auto t = triangulate_planar(p, {}, o);
  expect_valid_triangulation(p, t);
  EXPECT_EQ(t.angles_closed, 0u);
}

TEST(PlanarTriangulation, BlockedEdgesAreNeverUsed) {
  const std::vector<Point2> p = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  const std::vector<std::pair<int, int>> blocked = {{0, 2}};
  const auto t = triangulate_planar(p, blocked);
  expect_valid_triangulation(p, t);
  for (const auto& tri : t.triangles) {
    const bool has0 = tri[0] == 0 || tri[1] == 0 || tri[2] == 0;
    const bool has2 = tri[0] == 2 || tri[1] == 2 || tri[2] == 2;
    EXPECT_FALSE(has0 && has2);
  }
  const std::vector<std::pair<int, int>> both = {{0, 2}, {1, 3}};
  const auto impossible = triangulate_planar(p, both);
  EXPECT_FALSE(impossible.ok);
  EXPECT_FALSE(impossible.failure.empty());
}

TEST(PlanarTriangulation, TooFewVertices) {
  const std::vector<Point2> p = {{0, 0}, {1, 0}};
  EXPECT_FALSE(triangulate_planar(p, {}).ok);
}

}  // namespace
}  // namespace touchmend::geometry
