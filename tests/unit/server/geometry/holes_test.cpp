#include "server/geometry/holes.h"

#include <cmath>
#include <numbers>
#include <random>
#include <set>

#include <gtest/gtest.h>

#include "server/geometry/hole_filling.h"
#include "server/geometry/mesh_build.h"
#include "tests/support/mesh_factory.h"

namespace touchmend::geometry {
namespace {

using testing::grid;
using testing::remove_faces;

//! A 10x10 grid with the cells of [3,5]x[3,5] removed: one 8-edge square hole.
Mesh grid_with_square_hole() {
  const MeshSoup s = remove_faces(
      grid(10, 10), [](const Vec3& c) { return c[0] > 3 && c[0] < 5 && c[1] > 3 && c[1] < 5; });
  return build_mesh(s).mesh;
}

TEST(FindHoles, SquareHoleInAGrid) {
  const Mesh m = grid_with_square_hole();
  const auto found = find_holes(m);
  ASSERT_EQ(found.holes.size(), 2u);  // the outer border and the hole
  const Hole* hole = nullptr;
  for (const auto& h : found.holes)
    if (h.loop.size() == 8) hole = &h;
  ASSERT_NE(hole, nullptr);
  EXPECT_DOUBLE_EQ(hole->perimeter, 8.0);
  EXPECT_NEAR(hole->area, 4.0, 1e-12);
  EXPECT_NEAR(hole->normal[2], 1.0, 1e-12);
  EXPECT_NEAR(hole->newell_normal[2], 1.0, 1e-12);  // loop runs counter-clockwise seen from +z
  EXPECT_NEAR(hole->centroid[0], 4.0, 1e-12);
  EXPECT_NEAR(hole->centroid[1], 4.0, 1e-12);
  EXPECT_TRUE(hole->is_simple);
  EXPECT_EQ(hole->reference_source, "boundary-triangles");
  EXPECT_NEAR(hole->planarity, 0.0, 1e-12);
  // The id is the smallest vertex index of the loop.
  int smallest = 1 << 30;
  for (const auto v : hole->loop) smallest = std::min(smallest, v.idx());
  EXPECT_EQ(hole->id, static_cast<std::uint32_t>(smallest));
  // Walking the loop follows boundary halfedges.
  for (std::size_t i = 0; i < hole->loop.size(); ++i) {
    EXPECT_TRUE(m.is_boundary(hole->halfedges[i]));
    EXPECT_EQ(m.from_vertex_handle(hole->halfedges[i]), hole->loop[i]);
    EXPECT_EQ(m.to_vertex_handle(hole->halfedges[i]), hole->loop[(i + 1) % hole->loop.size()]);
  }
}

TEST(FindHoles, TwoHolesSharingAVertexAreSeparateLoops) {
  // Cells (3,3) and (4,4) removed: the holes touch at vertex (4,4) only.
  const MeshSoup s = remove_faces(grid(8, 8), [](const Vec3& c) {
    return (c[0] > 3 && c[0] < 4 && c[1] > 3 && c[1] < 4) ||
           (c[0] > 4 && c[0] < 5 && c[1] > 4 && c[1] < 5);
  });
  const BuildResult b = build_mesh(s);
  const auto found = find_holes(b.mesh);
  std::vector<const Hole*> inner;
  for (const auto& h : found.holes)
    if (h.loop.size() == 4) inner.push_back(&h);
  ASSERT_EQ(inner.size(), 2u);
  EXPECT_NE(inner[0]->id, inner[1]->id);
  // They share exactly one vertex, and each loop visits it once.
  std::set<int> a, c;
  for (const auto v : inner[0]->loop) a.insert(v.idx());
  for (const auto v : inner[1]->loop) c.insert(v.idx());
  EXPECT_EQ(a.size(), 4u);
  EXPECT_EQ(c.size(), 4u);
  int shared = 0;
  for (int v : a) shared += c.count(v) ? 1 : 0;
  EXPECT_EQ(shared, 1);
  EXPECT_NEAR(inner[0]->area, 1.0, 1e-12);
  EXPECT_NEAR(inner[1]->area, 1.0, 1e-12);
  EXPECT_EQ(found.corrupt_fans, 0u);
}

TEST(FindHoles, OpenCylinderEndsUseTheNewellNormal) {
  const BuildResult b = build_mesh(testing::cylinder(1.0, 2.0, 24, 5));
  const auto found = find_holes(b.mesh);
  ASSERT_EQ(found.holes.size(), 2u);
  for (const auto& h : found.holes) {
    EXPECT_EQ(h.loop.size(), 24u);
    EXPECT_TRUE(h.is_simple);
    EXPECT_NE(h.reference_source, "boundary-triangles");  // the radial normals cancel out
    EXPECT_NEAR(std::abs(h.reference_normal[2]), 1.0, 1e-9);
  }
}

TEST(FindHoles, PinchedLoopListsItsPinch) {
  MeshSoup s;
  s.points = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {-1, 0, 0}, {-1, -1, 0}};
  s.triangles = {{0, 1, 2}, {0, 3, 4}};  // a bowtie: its outside passes vertex 0 twice
  const auto holes = find_holes(build_mesh(s).mesh).holes;
  ASSERT_EQ(holes.size(), 1u);
  EXPECT_EQ(holes[0].loop.size(), 6u);
  EXPECT_EQ(holes[0].pinched_at, std::vector<VertexHandle>{VertexHandle(0)});
  EXPECT_TRUE(holes[0].unfillable_reason.empty()) << holes[0].unfillable_reason;
}

// A lone triangle beside a grid: its outline is a loop bordering a piece of one face; the grid's
// outer border borders a piece of 128 faces, far more than its 32 edges: no fragment.
TEST(FindHoles, OutlineOfALoneTriangleIsMarkedAsAFragment) {
  const MeshSoup s = testing::with_lone_triangle(testing::grid(8, 8), {20, 0, 0});
  const auto holes = find_holes(build_mesh(s).mesh).holes;
  ASSERT_EQ(holes.size(), 2u);
  for (const Hole& h : holes) EXPECT_EQ(h.fragment_faces, h.loop.size() == 3 ? 1u : 0u);
}

TEST(FindHoles, ClosedMeshHasNoHoles) {
  EXPECT_TRUE(find_holes(build_mesh(testing::uv_sphere(1, 12, 8)).mesh).holes.empty());
}

TEST(FindHoles, NearestHoleAndLookupById) {
  const Mesh m = grid_with_square_hole();
  const auto holes = find_holes(m).holes;
  const auto near = find_nearest_hole(m, holes, Vec3(4.0, 4.2, 0.5));
  ASSERT_TRUE(near);
  EXPECT_EQ(holes[near->index].loop.size(), 8u);
  EXPECT_NEAR(near->distance, std::sqrt(0.8 * 0.8 + 0.25), 1e-12);
  EXPECT_TRUE(find_hole_by_id(holes, holes[near->index].id));
  EXPECT_FALSE(find_hole_by_id(holes, 999999));
}

//! Two searches of one mesh agree hole by hole: loops in the same order with the same ids,
//! pinches, fragment counts, reasons and properties.
void expect_same_holes(const HoleSearchResult& updated, const HoleSearchResult& searched,
                       int step) {
  ASSERT_EQ(updated.holes.size(), searched.holes.size()) << "step " << step;
  for (std::size_t i = 0; i < searched.holes.size(); ++i) {
    const Hole& a = updated.holes[i];
    const Hole& b = searched.holes[i];
    SCOPED_TRACE(::testing::Message() << "step " << step << ", hole " << b.id);
    EXPECT_EQ(a.id, b.id);
    EXPECT_EQ(a.loop, b.loop);
    EXPECT_EQ(a.halfedges, b.halfedges);
    EXPECT_EQ(a.pinched_at, b.pinched_at);
    EXPECT_EQ(a.fragment_faces, b.fragment_faces);
    EXPECT_EQ(a.unfillable_reason, b.unfillable_reason);
    EXPECT_EQ(a.perimeter, b.perimeter);
    EXPECT_EQ(a.area, b.area);
    EXPECT_EQ(a.normal, b.normal);
    EXPECT_EQ(a.centroid, b.centroid);
    EXPECT_EQ(a.planarity, b.planarity);
    EXPECT_EQ(a.is_simple, b.is_simple);
    EXPECT_EQ(a.reference_normal, b.reference_normal);
  }
}

// A grid with a hole, two holes touching at a vertex and a lone triangle beside it, edited at
// random: faces deleted (new holes, holes merged, pinched or touching), holes filled, vertices
// moved. After every edit the update from the vertices it touched gives what a search of the
// whole mesh gives. Fails when the update keeps a loop an edit changed (a moved vertex's
// neighbours left out: a kept hole's normal is stale) or misses a new one.
TEST(UpdateHoles, GivesWhatASearchGivesAfterEveryEdit) {
  MeshSoup soup = remove_faces(grid(14, 14), [](const Vec3& c) {
    return (c[0] > 3 && c[0] < 5 && c[1] > 3 && c[1] < 5) ||
           (c[0] > 8 && c[0] < 9 && c[1] > 8 && c[1] < 9) ||
           (c[0] > 9 && c[0] < 10 && c[1] > 9 && c[1] < 10);
  });
  soup = testing::with_lone_triangle(soup, {30, 0, 0});
  Mesh mesh = build_mesh(soup).mesh;
  HoleSearchResult holes = find_holes(mesh);
  std::mt19937 random(20261128);
  const auto pick = [&](std::size_t n) {
    return std::uniform_int_distribution<std::size_t>(0, n - 1)(random);
  };
  std::size_t deleted = 0, filled = 0, moved = 0;
  for (int step = 0; step < 240; ++step) {
    std::vector<VertexHandle> touched;
    const int kind = step % 3;
    if (kind == 0) {
      std::vector<FaceHandle> alive;
      for (const FaceHandle f : mesh.faces()) alive.push_back(f);
      if (alive.empty()) break;
      const FaceHandle f = alive[pick(alive.size())];
      for (const VertexHandle v : mesh.fv_range(f)) touched.push_back(v);
      mesh.delete_face(f, false);
      ++deleted;
    } else if (kind == 1) {
      std::vector<std::uint32_t> small;
      for (const Hole& h : holes.holes)
        if (h.loop.size() <= 24) small.push_back(h.id);
      if (small.empty()) continue;
      FillSelection selection;
      selection.mode = FillSelection::Mode::Ids;
      selection.ids = {small[pick(small.size())]};
      const FillReport report = fill_holes(mesh, selection, FillOptions{}, {}, &holes);
      for (const HoleFillReport& r : report.holes) {
        const auto i = find_hole_by_id(holes.holes, r.hole_id);
        ASSERT_TRUE(i);
        for (const VertexHandle v : holes.holes[*i].loop) touched.push_back(v);
        for (const FaceHandle f : r.new_faces)
          for (const VertexHandle v : mesh.fv_range(f)) touched.push_back(v);
        filled += r.filled ? 1 : 0;
      }
    } else {
      std::vector<VertexHandle> alive;
      for (const VertexHandle v : mesh.vertices())
        if (!mesh.is_isolated(v)) alive.push_back(v);
      const VertexHandle v = alive[pick(alive.size())];
      mesh.set_point(
          v, mesh.point(v) + Vec3(0, 0, std::uniform_real_distribution<>(-0.3, 0.3)(random)));
      touched.push_back(v);
      for (const VertexHandle w : mesh.vv_range(v)) touched.push_back(w);
      ++moved;
    }
    HoleSearchResult updated = holes;
    ASSERT_TRUE(update_holes(mesh, updated, touched)) << "step " << step;
    const HoleSearchResult searched = find_holes(mesh);
    ASSERT_EQ(searched.corrupt_fans, 0u);
    expect_same_holes(updated, searched, step);
    if (::testing::Test::HasFailure()) return;
    holes = updated;
  }
  // The edits did what they are there for.
  EXPECT_EQ(deleted, 80u);
  EXPECT_GT(filled, 20u);
  EXPECT_EQ(moved, 80u);
}

// The update says when it cannot answer: after a search that met a corrupt fan it leaves the
// result as it was.
TEST(UpdateHoles, RefusesAfterACorruptSearch) {
  const Mesh mesh = grid_with_square_hole();
  HoleSearchResult holes = find_holes(mesh);
  holes.corrupt_fans = 1;
  const HoleSearchResult before = holes;
  const std::vector<VertexHandle> touched{VertexHandle(0)};
  EXPECT_FALSE(update_holes(mesh, holes, touched));
  EXPECT_EQ(holes.holes.size(), before.holes.size());
}

}  // namespace
}  // namespace touchmend::geometry
