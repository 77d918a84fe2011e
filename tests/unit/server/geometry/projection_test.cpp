#include "server/geometry/projection.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include <gtest/gtest.h>

namespace touchmend::geometry {
namespace {

TEST(ReferenceFrame, RotatesTheNormalToPlusZRightHanded) {
  for (const Vec3& n :
       {Vec3(0, 0, 1), Vec3(0, 0, -1), Vec3(1, 2, 3), Vec3(-1, 0, 0), Vec3(0.3, -0.9, -0.1)}) {
    const ReferenceFrame f = ReferenceFrame::from_normal(n, Vec3(1, 1, 1));
    const Vec3 u = n / n.norm();
    EXPECT_NEAR(f.e1.norm(), 1, 1e-12);
    EXPECT_NEAR(f.e2.norm(), 1, 1e-12);
    EXPECT_NEAR(OpenMesh::dot(f.e1, f.e2), 0, 1e-12);
    EXPECT_NEAR(OpenMesh::dot(OpenMesh::cross(f.e1, f.e2), u), 1, 1e-12);
    const Vec3 r = f.rotate(Vec3(1, 1, 1) + u);
    EXPECT_NEAR(r[0], 0, 1e-12);
    EXPECT_NEAR(r[1], 0, 1e-12);
    EXPECT_NEAR(r[2], 1, 1e-12);
  }
}

TEST(Polygon, SignedAreaAndSelfIntersections) {
  const std::vector<Point2> square = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  EXPECT_DOUBLE_EQ(signed_area(square), 1.0);
  EXPECT_EQ(count_self_intersections(square), 0u);
  const std::vector<Point2> bowtie = {{0, 0}, {1, 1}, {1, 0}, {0, 1}};
  EXPECT_GT(count_self_intersections(bowtie), 0u);
  const std::vector<Point2> spike = {{0, 0}, {2, 0}, {1, 0}, {1, 1}};  // folds back on itself
  EXPECT_GT(count_self_intersections(spike), 0u);
  const std::vector<Point2> touching = {
      {0, 0}, {2, 0}, {2, 2}, {1, 0}, {0, 2}};  // vertex on an edge
  EXPECT_GT(count_self_intersections(touching), 0u);
}

TEST(Projectability, ClockwiseFoldedAndSimpleLoops) {
  const std::vector<Vec3> ccw = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  const ReferenceFrame up = ReferenceFrame::from_normal(Vec3(0, 0, 1), Vec3(0.5, 0.5, 0));
  EXPECT_TRUE(test_projectable(ccw, {}, up, 0.05).projectable);
  const ReferenceFrame down = ReferenceFrame::from_normal(Vec3(0, 0, -1), Vec3(0.5, 0.5, 0));
  EXPECT_FALSE(test_projectable(ccw, {}, down, 0.05).projectable);
  // A neighbour folding back over the hole.
  const std::vector<Vec3> inside = {{0.5, 0.5, 1}};
  const auto folded = test_projectable(ccw, inside, up, 0.05);
  EXPECT_FALSE(folded.projectable);
  EXPECT_EQ(folded.fold_overs, 1u);
  // Neighbours on the boundary line (a wall) are fine.
  const std::vector<Vec3> wall = {{0.5, 0.0, -1}};
  EXPECT_TRUE(test_projectable(ccw, wall, up, 0.05).projectable);
}

// The fold-over guard's slabs must count exactly what testing every point against every edge
// counts: a star of 64 vertices, points all over and around it, some near its edges.
TEST(Projectability, FoldOversCountedAsByEveryEdge) {
  std::vector<Vec3> star;
  for (int i = 0; i < 64; ++i) {
    const double a = 2 * std::numbers::pi * i / 64, r = i % 2 == 0 ? 1.0 : 0.6;
    star.emplace_back(r * std::cos(a), r * std::sin(a), 0);
  }
  std::vector<Vec3> points;
  for (int x = 0; x < 41; ++x)
    for (int y = 0; y < 41; ++y) points.emplace_back(-1.2 + 0.06 * x, -1.2 + 0.06 * y, 1);
  const double tolerance = 0.05;
  const ReferenceFrame up = ReferenceFrame::from_normal(Vec3(0, 0, 1), Vec3(0, 0, 0));
  std::vector<Point2> polygon;
  for (const Vec3& p : star) polygon.push_back(up.project(p));
  std::size_t expected = 0;
  for (const Vec3& q3 : points) {
    const Point2 q = up.project(q3);
    if (!point_in_polygon(polygon, q)) continue;
    double d = HUGE_VAL;
    for (std::size_t i = 0; i < polygon.size(); ++i) {
      const Point2 a = polygon[i], b = polygon[(i + 1) % polygon.size()];
      const double t = std::clamp((q - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
      d = std::min(d, (a + t * (b - a) - q).norm());
    }
    expected += d > tolerance ? 1 : 0;
  }
  ASSERT_GT(expected, 50u);
  ASSERT_LT(expected, points.size() / 2);
  EXPECT_EQ(test_projectable(star, points, up, tolerance).fold_overs, expected);
}

TEST(Projectability, PcaNormalOfATiltedPlane) {
  std::vector<Vec3> pts;
  for (int i = 0; i < 12; ++i) {
    const double a = 2 * std::numbers::pi * i / 12;
    pts.emplace_back(std::cos(a), std::sin(a), 0.5 * std::cos(a));
  }
  const Vec3 n = pca_normal(pts, Vec3(0, 0, 1));
  const Vec3 expected = Vec3(-0.5, 0, 1) / std::sqrt(1.25);
  EXPECT_NEAR(OpenMesh::dot(n, expected), 1.0, 1e-9);
}

}  // namespace
}  // namespace touchmend::geometry
