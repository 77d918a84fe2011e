#include "server/geometry/intersection.h"

#include <cmath>

#include <gtest/gtest.h>

#include "server/geometry/mesh_build.h"
#include "server/geometry/mesh_intersections.h"
#include "tests/support/mesh_factory.h"

namespace touchmend::geometry {
namespace {

const TrianglePoints kFloor = {Vec3(0, 0, 0), Vec3(2, 0, 0), Vec3(0, 2, 0)};

TEST(TrianglesIntersect, GeneralPosition) {
  const TrianglePoints piercing = {Vec3(0.5, 0.5, -1), Vec3(0.5, 0.5, 1), Vec3(1.5, 1.5, 1)};
  EXPECT_TRUE(triangles_intersect(kFloor, {0, 1, 2}, piercing, {3, 4, 5}));
  const TrianglePoints above = {Vec3(0, 0, 1), Vec3(2, 0, 1), Vec3(0, 2, 1)};
  EXPECT_FALSE(triangles_intersect(kFloor, {0, 1, 2}, above, {3, 4, 5}));
  const TrianglePoints overlapping = {Vec3(0.2, 0.2, 0), Vec3(3, 0.2, 0), Vec3(0.2, 3, 0)};
  EXPECT_TRUE(triangles_intersect(kFloor, {0, 1, 2}, overlapping, {3, 4, 5}));
}

TEST(TrianglesIntersect, SharedVertexOrEdgeIsNotAnIntersection) {
  const TrianglePoints fan = {Vec3(0, 0, 0), Vec3(0, -2, 0), Vec3(2, -1, 1)};  // shares corner 0
  EXPECT_FALSE(triangles_intersect(kFloor, {0, 1, 2}, fan, {0, 7, 8}));
  const TrianglePoints crossing = {Vec3(0, 0, 0), Vec3(0.5, 0.5, -1),
                                   Vec3(0.5, 0.5, 1)};  // shares 0, cuts through
  EXPECT_TRUE(triangles_intersect(kFloor, {0, 1, 2}, crossing, {0, 7, 8}));
  const TrianglePoints hinge = {Vec3(2, 0, 0), Vec3(0, 2, 0), Vec3(2, 2, 1)};  // shares edge 1-2
  EXPECT_FALSE(triangles_intersect(kFloor, {0, 1, 2}, hinge, {1, 2, 9}));
  const TrianglePoints folded = {Vec3(2, 0, 0), Vec3(0, 2, 0), Vec3(0.2, 0.2, 0)};  // folds onto it
  EXPECT_TRUE(triangles_intersect(kFloor, {0, 1, 2}, folded, {1, 2, 9}));
  EXPECT_TRUE(triangles_intersect(kFloor, {0, 1, 2}, kFloor, {0, 1, 2}));
}

TEST(ClosestPoint, RegionsOfTheTriangle) {
  EXPECT_EQ(closest_point_on_triangle(Vec3(0.5, 0.5, 3), kFloor), Vec3(0.5, 0.5, 0));
  EXPECT_EQ(closest_point_on_triangle(Vec3(-1, -1, 0), kFloor), Vec3(0, 0, 0));
  EXPECT_EQ(closest_point_on_triangle(Vec3(1, -1, 0), kFloor), Vec3(1, 0, 0));
  EXPECT_NEAR(segment_triangle_distance(Vec3(0.5, 0.5, 1), Vec3(0.5, 0.5, 2), kFloor), 1.0, 1e-12);
  EXPECT_EQ(segment_triangle_distance(Vec3(0.5, 0.5, 1), Vec3(0.5, 0.5, -2), kFloor), 0.0);
}

TEST(MeshIntersections, ClosedMeshesDoNotSelfIntersectButOverlapsDo) {
  const Mesh cube = build_mesh(testing::cube(3)).mesh;
  EXPECT_TRUE(find_self_intersections(cube).empty());
  const Mesh sphere = build_mesh(testing::uv_sphere(1, 16, 10)).mesh;
  EXPECT_TRUE(find_self_intersections(sphere).empty());
  // Two cubes through each other.
  MeshSoup a = testing::cube(1), b = testing::cube(1);
  const auto offset = static_cast<std::uint32_t>(a.points.size());
  for (auto p : b.points) a.points.push_back(p + Vec3(0.5, 0.5, 0.5));
  for (auto t : b.triangles) a.triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
  EXPECT_FALSE(find_self_intersections(build_mesh(a).mesh).empty());
}

TEST(MeshIntersections, InjectiveProjectionAndTestsAgainstTheRest) {
  // A wavy graph z = f(x, y) projects injectively onto z = 0, whatever its heights.
  Mesh wavy = build_mesh(testing::grid(6, 6, [](double x, double y) {
                return 0.3 * std::sin(x) * std::cos(y);
              })).mesh;
  std::vector<FaceHandle> all(wavy.faces().begin(), wavy.faces().end());
  const ReferenceFrame plane = ReferenceFrame::from_normal(Vec3(0, 0, 1), Vec3(0, 0, 0));
  EXPECT_TRUE(projects_injectively(wavy, all, plane));
  // Seen edge-on (the plane's normal along x) every triangle flattens or flips: not injective.
  EXPECT_FALSE(
      projects_injectively(wavy, all, ReferenceFrame::from_normal(Vec3(1, 0, 0), Vec3(0, 0, 0))));
  // Fold one interior vertex over its neighbours: some triangles flip in projection.
  Mesh folded = build_mesh(testing::grid(4, 4)).mesh;
  for (const VertexHandle v : folded.vertices()) {
    const Vec3 p = folded.point(v);
    if (p == Vec3(2, 2, 0)) folded.set_point(v, Vec3(3.5, 2.2, 0));
  }
  std::vector<FaceHandle> folded_faces(folded.faces().begin(), folded.faces().end());
  EXPECT_FALSE(projects_injectively(folded, folded_faces, plane));
  EXPECT_FALSE(find_self_intersections(folded).empty());

  // find_intersections_with_rest skips pairs inside the chosen set, not pairs with the rest.
  MeshSoup two = testing::grid(2, 2);
  const auto offset = static_cast<std::uint32_t>(two.points.size());
  for (const Vec3& p : testing::grid(2, 2).points) two.points.push_back(Vec3(1, p[1], p[0] - 1));
  for (const auto& t : testing::grid(2, 2).triangles)
    two.triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
  const Mesh crossing = build_mesh(two).mesh;
  std::vector<FaceHandle> first_sheet;
  for (const FaceHandle f : crossing.faces())
    if (f.idx() < 8) first_sheet.push_back(f);
  EXPECT_FALSE(find_intersections_with_rest(crossing, first_sheet).empty());
  EXPECT_FALSE(find_face_intersections(crossing, first_sheet).empty());
  std::vector<FaceHandle> both(crossing.faces().begin(), crossing.faces().end());
  EXPECT_TRUE(find_intersections_with_rest(crossing, both).empty());
  EXPECT_FALSE(find_face_intersections(crossing, both).empty());
}

}  // namespace
}  // namespace touchmend::geometry
