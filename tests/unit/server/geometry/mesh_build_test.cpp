#include "server/geometry/mesh_build.h"

#include <gtest/gtest.h>

#include "tests/support/mesh_factory.h"

namespace touchmend::geometry {
namespace {

MeshSoup square() {  // two triangles over the unit square, counter-clockwise from +z
  MeshSoup s;
  s.points = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  s.triangles = {{0, 1, 2}, {0, 2, 3}};
  return s;
}

TEST(BuildMesh, CleanMeshHasNoDefects) {
  const BuildResult b = build_mesh(testing::cube(2));
  EXPECT_TRUE(b.report.is_clean());
  EXPECT_EQ(b.report.boundary_edges, 0u);
  EXPECT_EQ(b.report.boundary_loops, 0u);
  EXPECT_EQ(b.mesh.n_faces(), 48u);
}

TEST(BuildMesh, NonManifoldEdgeIsReportedAndTheThirdFaceRefused) {
  MeshSoup s = square();
  s.points.push_back({0.5, 0.5, 1});
  s.triangles.push_back({0, 2, 4});  // a third face on edge 0-2
  const BuildResult b = build_mesh(s);
  EXPECT_EQ(b.report.non_manifold_edges, 1u);
  ASSERT_EQ(b.report.refused_faces.size(), 1u);
  EXPECT_EQ(b.report.refused_faces[0].face_index, 2u);
  EXPECT_EQ(b.mesh.n_faces(), 2u);
  EXPECT_FALSE(b.report.is_clean());
}

TEST(BuildMesh, FlippedNeighbourIsReported) {
  MeshSoup s = square();
  s.triangles[1] = {0, 3, 2};  // uses 2->0 like face 0: the two faces disagree on orientation
  const BuildResult b = build_mesh(s);
  EXPECT_EQ(b.report.inconsistent_edges, 1u);
  EXPECT_EQ(b.report.refused(RefusedFaceReason::FlippedNeighbour), 1u);
}

TEST(BuildMesh, DegenerateAndDuplicateFaces) {
  MeshSoup s = square();
  s.triangles.push_back({1, 1, 2});  // repeated vertex
  s.triangles.push_back({2, 0, 1});  // duplicate of face 0 (rotated)
  s.points.push_back({2, 0, 0});
  s.triangles.push_back({1, 4, 4});
  const BuildResult b = build_mesh(s);
  EXPECT_EQ(b.report.refused(RefusedFaceReason::RepeatedVertex), 2u);
  EXPECT_EQ(b.report.refused(RefusedFaceReason::DuplicateFace), 1u);
  EXPECT_EQ(b.report.duplicate_faces, 1u);
  EXPECT_GE(b.report.degenerate_faces, 2u);
  EXPECT_EQ(b.mesh.n_faces(), 2u);
}

TEST(BuildMesh, CollinearFaceIsCountedDegenerateButKept) {
  MeshSoup s = square();
  s.points.push_back({2, 0, 0});
  s.points.push_back({3, 0, 0});
  s.triangles.push_back({1, 4, 5});  // zero area, distinct corners
  const BuildResult b = build_mesh(s);
  EXPECT_EQ(b.report.degenerate_faces, 1u);
  EXPECT_EQ(b.mesh.n_faces(), 3u);
}

TEST(BuildMesh, BowtieVertexIsNonManifold) {
  MeshSoup s;
  s.points = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {-1, 0, 0}, {-1, -1, 0}};
  s.triangles = {{0, 1, 2}, {0, 3, 4}};  // two fans meeting at vertex 0
  const BuildResult b = build_mesh(s);
  EXPECT_EQ(b.report.non_manifold_vertices, 1u);
  EXPECT_EQ(b.mesh.n_faces(), 2u);
  // The outside of a bowtie is one region: one boundary loop through vertex 0 twice.
  EXPECT_EQ(b.report.boundary_loops, 1u);
}

TEST(BuildMesh, UnreferencedVerticesKeepTheirIndices) {
  MeshSoup s = square();
  s.points.insert(s.points.begin(), Vec3(7, 7, 7));
  for (auto& t : s.triangles)
    for (auto& v : t) ++v;
  const BuildResult b = build_mesh(s);
  EXPECT_EQ(b.report.unreferenced_vertices, 1u);
  EXPECT_EQ(b.mesh.n_vertices(), 5u);
  EXPECT_EQ(b.mesh.point(VertexHandle(0)), Vec3(7, 7, 7));
}

}  // namespace
}  // namespace touchmend::geometry
