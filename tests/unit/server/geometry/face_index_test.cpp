#include "server/geometry/face_index.h"

#include <random>
#include <set>

#include <gtest/gtest.h>

#include "server/geometry/mesh_build.h"
#include "tests/support/mesh_factory.h"

namespace touchmend::geometry {
namespace {

std::set<int> brute_force(const Mesh& mesh, const Box3& box) {
  std::set<int> out;
  for (const FaceHandle f : mesh.faces())
    if (FaceIndex::face_box(mesh, f).intersects(box)) out.insert(f.idx());
  return out;
}

std::set<int> indexed(const Mesh& mesh, const FaceIndex& index, const Box3& box) {
  std::set<int> out;
  index.for_each_in_box(mesh, box, [&](FaceHandle f) {
    EXPECT_TRUE(out.insert(f.idx()).second) << "face " << f.idx() << " visited twice";
  });
  return out;
}

Box3 random_box(std::mt19937& rng, double lo, double hi, double max_size) {
  std::uniform_real_distribution<double> at(lo, hi), size(0, max_size);
  const Eigen::Vector3d corner(at(rng), at(rng), at(rng));
  return Box3(corner, corner + Eigen::Vector3d(size(rng), size(rng), size(rng)));
}

TEST(FaceIndex, FindsExactlyTheFacesWhoseBoxesMeetTheQuery) {
  // A sphere plus one huge sliver across it (filed on the list every query checks).
  MeshSoup s = testing::uv_sphere(1.0, 40, 30);
  const auto base = static_cast<std::uint32_t>(s.points.size());
  s.points.push_back({-5, -5, 0});
  s.points.push_back({5, 5, 0.001});
  s.points.push_back({5, 5.01, 0});
  s.triangles.push_back({base, base + 1, base + 2});
  const Mesh mesh = build_mesh(s).mesh;
  const FaceIndex index(mesh);
  std::mt19937 rng(7);
  for (int i = 0; i < 200; ++i) {
    const Box3 box = random_box(rng, -1.5, 1.5, i < 150 ? 0.2 : 3.0);
    EXPECT_EQ(indexed(mesh, index, box), brute_force(mesh, box)) << "query " << i;
  }
}

TEST(FaceIndex, SeesAddedFacesAndSkipsDeletedOnes) {
  Mesh mesh = build_mesh(testing::grid(10, 10)).mesh;
  FaceIndex index(mesh);
  const VertexHandle a = mesh.add_vertex({2, 2, 1}), b = mesh.add_vertex({3, 2, 1}),
                     c = mesh.add_vertex({2, 3, 1});
  const FaceHandle added = mesh.add_face(a, b, c);
  ASSERT_TRUE(added.is_valid());
  const Box3 above(Eigen::Vector3d(1.5, 1.5, 0.5), Eigen::Vector3d(3.5, 3.5, 1.5));
  EXPECT_TRUE(indexed(mesh, index, above).empty());  // not filed yet
  index.insert(mesh, added);
  EXPECT_EQ(indexed(mesh, index, above), std::set<int>{added.idx()});
  mesh.delete_face(added, true);
  EXPECT_TRUE(indexed(mesh, index, above).empty());
  // Deleting a filed face of the grid hides it too.
  const Box3 cell(Eigen::Vector3d(5.2, 5.2, -0.1), Eigen::Vector3d(5.3, 5.3, 0.1));
  const std::set<int> before = indexed(mesh, index, cell);
  ASSERT_FALSE(before.empty());
  mesh.delete_face(FaceHandle(*before.begin()), false);
  EXPECT_EQ(indexed(mesh, index, cell).count(*before.begin()), 0u);
}

}  // namespace
}  // namespace touchmend::geometry
