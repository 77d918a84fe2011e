#include "server/geometry/metrics.h"

#include <cmath>

#include <gtest/gtest.h>

#include "server/geometry/mesh_build.h"
#include "tests/support/mesh_factory.h"

namespace touchmend::geometry {
namespace {

std::vector<TrianglePoints> triangles_of(const MeshSoup& s, const Vec3& offset = Vec3(0, 0, 0)) {
  std::vector<TrianglePoints> out;
  for (const auto& t : s.triangles)
    out.push_back({s.points[t[0]] + offset, s.points[t[1]] + offset, s.points[t[2]] + offset});
  return out;
}

TEST(SurfaceDistance, IdenticalSetsAreAtZeroAndOffsetsAreMeasured) {
  const auto a = triangles_of(testing::grid(4, 4));
  const auto same = surface_distance(a, a, 0.1);
  ASSERT_TRUE(same.valid);
  EXPECT_NEAR(same.hausdorff, 0.0, 1e-12);
  EXPECT_NEAR(same.mean, 0.0, 1e-12);
  const auto shifted =
      surface_distance(a, triangles_of(testing::grid(4, 4), Vec3(0, 0, 0.25)), 0.1);
  EXPECT_NEAR(shifted.hausdorff, 0.25, 1e-12);
  EXPECT_NEAR(shifted.mean, 0.25, 1e-12);
  EXPECT_NEAR(shifted.normal_deviation_deg, 0.0, 1e-9);
  // One-sided: a small patch inside a big one.
  const auto big = triangles_of(testing::grid(8, 8));
  const auto d = surface_distance(a, big, 0.1);
  EXPECT_NEAR(d.h_a_to_b, 0.0, 1e-12);
  EXPECT_NEAR(d.h_b_to_a, std::sqrt(32.0), 1e-9);
  EXPECT_FALSE(surface_distance({}, a, 0.1).valid);
}

TEST(TriangleQuality, EquilateralAndSliver) {
  const std::vector<TrianglePoints> eq = {
      {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0.5, std::sqrt(3.0) / 2, 0)}};
  const auto q = triangle_quality(eq);
  EXPECT_NEAR(q.min_angle_deg, 60.0, 1e-9);
  EXPECT_NEAR(q.max_aspect_ratio, 1.0, 1e-9);
  const std::vector<TrianglePoints> sliver = {{Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0.5, 0.01, 0)}};
  const auto s = triangle_quality(sliver);
  EXPECT_LT(s.min_angle_deg, 2.0);
  EXPECT_EQ(s.below_10_deg, 1u);
  EXPECT_GT(s.max_aspect_ratio, 10.0);
  const std::vector<TrianglePoints> flat = {{Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(2, 0, 0)}};
  EXPECT_EQ(triangle_quality(flat).degenerate, 1u);
}

TEST(ValidateMesh, RoundTripsTheMeshArrays) {
  const Mesh m = build_mesh(testing::cube(2)).mesh;
  const MeshSoup s = to_soup(m);
  EXPECT_EQ(s.points.size(), m.n_vertices());
  EXPECT_EQ(s.triangles.size(), m.n_faces());
  EXPECT_TRUE(validate_mesh(m).is_clean());
  EXPECT_NEAR(bounding_box_diagonal(m), std::sqrt(12.0), 1e-12);
}

}  // namespace
}  // namespace touchmend::geometry
