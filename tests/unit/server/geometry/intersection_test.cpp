#include "server/geometry/intersection.h"

#include <algorithm>
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "server/geometry/bvh.h"
#include "server/geometry/mesh_build.h"
#include "server/geometry/mesh_intersections.h"
#include "tests/support/mesh_factory.h"

namespace touchmend::geometry {
namespace {

const TrianglePoints kFloor = {Vec3(0, 0, 0), Vec3(2, 0, 0), Vec3(0, 2, 0)};

//! Two 2 x 2 grids that cut through each other: z = 0 (faces 0-7) and x = 1 (faces 8-15).
Mesh two_crossing_sheets() {
  MeshSoup two = testing::grid(2, 2);
  const auto offset = static_cast<std::uint32_t>(two.points.size());
  for (const Vec3& p : testing::grid(2, 2).points) two.points.push_back(Vec3(1, p[1], p[0] - 1));
  for (const auto& t : testing::grid(2, 2).triangles)
    two.triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
  return build_mesh(two).mesh;
}

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

// Triangles side by side in (nearly) one plane, as around a patch on a planar CAD face: apart
// they do not intersect, whatever the rounding off the plane; touching at a corner or along a
// side they do (touching counts), also when a margin separates everything else.
TEST(TrianglesIntersect, SideBySideInOnePlane) {
  const TrianglePoints apart = {Vec3(2.001, 0.5, 1e-13), Vec3(3, 0.5, -1e-13), Vec3(2.5, 1, 0)};
  EXPECT_FALSE(triangles_intersect(kFloor, {0, 1, 2}, apart, {3, 4, 5}));
  EXPECT_FALSE(triangles_intersect(apart, {3, 4, 5}, kFloor, {0, 1, 2}));
  // A corner on the floor's long side (x + y = 2), the rest beyond it.
  const TrianglePoints touching = {Vec3(1, 1, 0), Vec3(3, 1, 0.5), Vec3(1, 3, -0.5)};
  EXPECT_TRUE(triangles_intersect(kFloor, {0, 1, 2}, touching, {3, 4, 5}));
  EXPECT_TRUE(triangles_intersect(touching, {3, 4, 5}, kFloor, {0, 1, 2}));
  // Across the floor's side: a sliver standing on it.
  const TrianglePoints across = {Vec3(1.5, 0.2, 0), Vec3(3, 0.2, 0), Vec3(3, 0.3, 0)};
  EXPECT_TRUE(triangles_intersect(kFloor, {0, 1, 2}, across, {3, 4, 5}));
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
  const Mesh crossing = two_crossing_sheets();
  std::vector<FaceHandle> first_sheet;
  for (const FaceHandle f : crossing.faces())
    if (f.idx() < 8) first_sheet.push_back(f);
  EXPECT_FALSE(find_intersections_with_rest(crossing, first_sheet).empty());
  EXPECT_FALSE(find_face_intersections(crossing, first_sheet).empty());
  std::vector<FaceHandle> both(crossing.faces().begin(), crossing.faces().end());
  EXPECT_TRUE(find_intersections_with_rest(crossing, both).empty());
  EXPECT_FALSE(find_face_intersections(crossing, both).empty());
}

// A region of a split patch: a disk that projects injectively onto its own plane, whatever its
// orientation in space; not when it folds, nor when it is no disk.
TEST(MeshIntersections, DiskProjectsInjectivelyOntoItsOwnPlane) {
  // A wavy grid tilted 70° about x: no frame is given, the faces' mean normal is found.
  Mesh tilted = build_mesh(testing::grid(6, 6, [](double x, double y) {
                  return 0.3 * std::sin(x) * std::cos(y);
                })).mesh;
  const double c = std::cos(1.22), s = std::sin(1.22);
  for (const VertexHandle v : tilted.vertices()) {
    const Vec3 p = tilted.point(v);
    tilted.set_point(v, Vec3(p[0], c * p[1] - s * p[2], s * p[1] + c * p[2]));
  }
  std::vector<FaceHandle> all(tilted.faces().begin(), tilted.faces().end());
  EXPECT_TRUE(disk_projects_injectively(tilted, all));
  // An interior vertex folded over its neighbours.
  Mesh folded = build_mesh(testing::grid(4, 4)).mesh;
  for (const VertexHandle v : folded.vertices())
    if (folded.point(v) == Vec3(2, 2, 0)) folded.set_point(v, Vec3(3.5, 2.2, 0));
  std::vector<FaceHandle> folded_faces(folded.faces().begin(), folded.faces().end());
  EXPECT_FALSE(disk_projects_injectively(folded, folded_faces));
  // A ring of faces (its boundary is two loops) is no disk, flat as it is.
  Mesh ring = build_mesh(testing::annulus(12, 1.0, 2, 0.5)).mesh;
  std::vector<FaceHandle> ring_faces(ring.faces().begin(), ring.faces().end());
  EXPECT_FALSE(disk_projects_injectively(ring, ring_faces));
  // Two faces meeting only at a vertex (the grid's centre, 1 1 0): the boundary passes that
  // vertex twice.
  Mesh grid = build_mesh(testing::grid(2, 2)).mesh;
  std::vector<FaceHandle> bowtie;
  for (const FaceHandle f : grid.faces()) {
    const Vec3 centroid = grid.calc_face_centroid(f);
    if ((centroid - Vec3(2.0 / 3, 1.0 / 3, 0)).norm() < 1e-9 ||
        (centroid - Vec3(5.0 / 3, 4.0 / 3, 0)).norm() < 1e-9)
      bowtie.push_back(f);
  }
  ASSERT_EQ(bowtie.size(), 2u);
  EXPECT_FALSE(disk_projects_injectively(grid, bowtie));
  EXPECT_FALSE(disk_projects_injectively(grid, {}));
}

// Pairs within an embedded group are skipped, pairs across groups and within a group not known
// to be embedded are tested.
TEST(MeshIntersections, GroupsSkipOnlyTheirOwnPairs) {
  const Mesh crossing = two_crossing_sheets();
  const SearchReach reach = make_search_reach(crossing);
  std::vector<FaceHandle> faces(crossing.faces().begin(), crossing.faces().end());
  std::vector<int> by_sheet;
  for (const FaceHandle f : faces) by_sheet.push_back(f.idx() < 8 ? 0 : 1);
  const std::vector<char> both_embedded{1, 1};
  EXPECT_FALSE(find_intersections_between_groups(crossing, faces, by_sheet, both_embedded, 0, reach)
                   .empty());
  // One group holding both sheets: tested when it is not known to be embedded, skipped when
  // the caller vouches for it.
  const std::vector<int> one_group(faces.size(), 0);
  EXPECT_FALSE(
      find_intersections_between_groups(crossing, faces, one_group, std::vector<char>{0}, 0, reach)
          .empty());
  EXPECT_TRUE(
      find_intersections_between_groups(crossing, faces, one_group, std::vector<char>{1}, 0, reach)
          .empty());
}

//! The faces whose boxes meet \p box, by a scan of every face (what a search must find).
std::vector<int> faces_meeting_by_scan(const Mesh& mesh, const Box3& box) {
  std::vector<int> out;
  for (const FaceHandle f : mesh.faces()) {
    TrianglePoints t;
    std::array<int, 3> ids;
    face_corners(mesh, f, t, ids);
    if (triangle_box(t).intersects(box)) out.push_back(f.idx());
  }
  return out;
}

//! The faces a search with \p reach finds for \p box, in index order.
//! The axis-aligned cube of half-side \p size around \p c.
Box3 box_around(const Vec3& c, double size) {
  return Box3(Eigen::Vector3d(c[0] - size, c[1] - size, c[2] - size),
              Eigen::Vector3d(c[0] + size, c[1] + size, c[2] + size));
}

std::vector<int> faces_found(const Mesh& mesh, const Box3& box, const SearchReach& reach) {
  std::vector<int> out;
  for (const FaceHandle f : faces_in_box(mesh, box, reach)) out.push_back(f.idx());
  std::sort(out.begin(), out.end());
  return out;
}

// A reach kept across edits, as a session keeps it: vertices moved (some far, stretching their
// faces past the reach) and noted, after the grid was filed. Its searches still find every face
// a scan finds. Without note_moved they miss the moved vertices' faces (the Debug build's check
// of the skipped runs stops there first).
TEST(MeshIntersections, SearchReachKeptThroughMovesFindsWhatAScanFinds) {
  Mesh mesh = build_mesh(testing::uv_sphere(1, 128, 72)).mesh;
  SearchReach reach = make_search_reach(mesh);
  ASSERT_GT(reach.grid_below, 0u);
  const auto scan = [&](const Box3& box) { return faces_meeting_by_scan(mesh, box); };
  const auto searched = [&](const Box3& box) { return faces_found(mesh, box, reach); };
  std::mt19937 random(5);
  std::uniform_real_distribution<> unit(-1, 1);
  const std::size_t listed = reach.long_faces.size();
  for (int round = 0; round < 6; ++round) {
    // File the grid (as if the searches had read as much as filing costs), then move.
    reach.scanned = SearchReach::kScansBeforeFiling * reach.grid_below;
    searched(box_around(Vec3(0, 0, 1), 0.01));
    EXPECT_FALSE(reach.grid.empty());
    std::vector<Vec3> moved_to;
    for (int k = 0; k < 8; ++k) {
      const VertexHandle v(static_cast<int>(
          std::uniform_int_distribution<std::size_t>(0, mesh.n_vertices() - 1)(random)));
      const double far = k % 2 == 0 ? 0.02 : 0.6;  // within a run's reach, or far out
      mesh.set_point(v, mesh.point(v) + far * Vec3(unit(random), unit(random), unit(random)));
      reach.note_moved(mesh, v);
      moved_to.push_back(mesh.point(v));
    }
    EXPECT_TRUE(reach.grid.empty());
    // A corner of a face already long moves again, far: its listing must follow it.
    if (reach.long_faces.size() > listed) {
      const FaceHandle f = reach.long_faces.back();
      const VertexHandle v = *mesh.fv_range(f).begin();
      mesh.set_point(v, mesh.point(v) + Vec3(0.5, -0.5, 0.5));
      reach.note_moved(mesh, v);
      moved_to.push_back(mesh.point(v));
    }
    // A fill's new vertices and faces, off the sphere: every other round they are boxed as runs
    // (box_new_vertices), else read one by one past the runs.
    const Vec3 base(unit(random), unit(random), unit(random));
    const VertexHandle hub = mesh.add_vertex(base * 1.1 - Vec3(0.4, 0, 0));  // apart: its own box
    std::vector<FaceHandle> added;
    for (int k = 0; k < 40; ++k) {
      const VertexHandle a = mesh.add_vertex(base * 1.1 + Vec3(0.01 * k, 0.02, 0.01));
      const VertexHandle b = mesh.add_vertex(base * 1.1 + Vec3(0.01 * k, -0.02, 0.3 * (k % 3)));
      added.push_back(mesh.add_face(hub, a, b));
      moved_to.push_back(mesh.point(b));
    }
    reach.add(mesh, added);
    if (round % 2 == 1) {
      reach.box_new_vertices(mesh);
      EXPECT_EQ(reach.blocks_below, mesh.n_vertices());
    }
    // The rule the runs rest on: every vertex below blocks_below lies in its run's box.
    for (std::size_t v = 0; v < reach.blocks_below; ++v) {
      const Vec3& p = mesh.point(VertexHandle(static_cast<int>(v)));
      ASSERT_TRUE(reach.block_boxes[v / SearchReach::kVertexBlock].contains(
          Eigen::Vector3d(p[0], p[1], p[2])))
          << "round " << round << ", vertex " << v;
    }
    for (const Vec3& p : moved_to)
      for (const double size : {0.001, 0.05, 0.3}) {
        const Box3 box = box_around(p, size);
        ASSERT_EQ(searched(box), scan(box)) << "round " << round;
      }
    for (int i = 0; i < 40; ++i) {
      const Vec3 c(unit(random) * 1.3, unit(random) * 1.3, unit(random) * 1.3);
      const Box3 box = box_around(c, 0.01 * (1 + i));
      ASSERT_EQ(searched(box), scan(box)) << "round " << round << ", box " << i;
    }
  }
  EXPECT_GT(reach.long_faces.size(), listed);  // the far moves made long faces
}

// A session drops the deleted elements at the end of the mesh's arrays after an undo
// (drop_deleted_tail) and keeps its reach (cut_back): the indices past the cut are then taken by
// new vertices anywhere, and the searches must still find what a scan finds. Cut first above
// the filed grid and the boxed runs (a fill undone), then into them (a part of the mesh itself).
TEST(MeshIntersections, SearchReachCutBackWithTheMeshFindsWhatAScanFinds) {
  Mesh mesh = build_mesh(testing::uv_sphere(1, 128, 72)).mesh;
  const std::size_t sphere_vertices = mesh.n_vertices();
  const std::size_t sphere_faces = mesh.n_faces();
  SearchReach reach = make_search_reach(mesh);
  ASSERT_GT(reach.grid_below, 0u);
  const auto scan = [&](const Box3& box) { return faces_meeting_by_scan(mesh, box); };
  const auto searched = [&](const Box3& box) { return faces_found(mesh, box, reach); };
  std::mt19937 random(7);
  std::uniform_real_distribution<> unit(-1, 1);
  // A fan of new faces round a hub near \p at, long ones among them; filed and boxed.
  const auto add_fan = [&](const Vec3& at) {
    std::vector<Vec3> points;
    const VertexHandle hub = mesh.add_vertex(at);
    std::vector<FaceHandle> added;
    for (int k = 0; k < 40; ++k) {
      const VertexHandle a = mesh.add_vertex(at + Vec3(0.01 * k, 0.02, 0.01));
      const VertexHandle b = mesh.add_vertex(at + Vec3(0.01 * k, -0.02, 0.3 * (k % 3)));
      added.push_back(mesh.add_face(hub, a, b));
      points.push_back(mesh.point(b));
    }
    reach.add(mesh, added);
    reach.box_new_vertices(mesh);
    return std::pair(added, points);
  };
  const auto check = [&](const std::vector<Vec3>& near, const char* what) {
    for (std::size_t v = 0; v < std::min(reach.blocks_below, mesh.n_vertices()); ++v) {
      const Vec3& p = mesh.point(VertexHandle(static_cast<int>(v)));
      if (mesh.status(VertexHandle(static_cast<int>(v))).deleted()) continue;
      ASSERT_TRUE(reach.block_boxes[v / SearchReach::kVertexBlock].contains(
          Eigen::Vector3d(p[0], p[1], p[2])))
          << what << ", vertex " << v;
    }
    for (const Vec3& p : near)
      for (const double size : {0.001, 0.05, 0.3}) {
        const Box3 box = box_around(p, size);
        ASSERT_EQ(searched(box), scan(box)) << what;
      }
    for (int i = 0; i < 40; ++i) {
      const Vec3 c(unit(random) * 1.3, unit(random) * 1.3, unit(random) * 1.3);
      const Box3 box = box_around(c, 0.01 * (1 + i));
      ASSERT_EQ(searched(box), scan(box)) << what << ", box " << i;
    }
  };
  const auto file_grid = [&] {
    reach.scanned = SearchReach::kScansBeforeFiling * reach.grid_below;
    searched(box_around(Vec3(0, 0, 1), 0.01));
    ASSERT_FALSE(reach.grid.empty());
  };

  // A fill and its undo: the arrays go back to the sphere's.
  file_grid();
  auto [fill, fill_points] = add_fan(Vec3(1.2, 0, 0));
  check(fill_points, "after the fill");
  for (const FaceHandle f : fill) mesh.delete_face(f, true);
  EXPECT_TRUE(drop_deleted_tail(mesh));
  EXPECT_FALSE(drop_deleted_tail(mesh));  // nothing left to drop
  EXPECT_EQ(mesh.n_vertices(), sphere_vertices);
  EXPECT_EQ(mesh.n_faces(), sphere_faces);
  reach.cut_back(mesh.n_vertices(), mesh.n_faces());
  EXPECT_EQ(reach.long_faces.size(), reach.long_boxes.size());
  for (const FaceHandle f : reach.long_faces) EXPECT_LT(f.idx(), static_cast<int>(sphere_faces));
  // Another fill elsewhere takes the same indices.
  auto [other, other_points] = add_fan(Vec3(0, -1.2, 0.3));
  check(other_points, "after a fill in the undone one's slots");

  // Into the sphere: every face at its last vertices goes, and they with them.
  for (const FaceHandle f : other) mesh.delete_face(f, true);
  file_grid();
  std::vector<FaceHandle> at_last;
  for (std::size_t v = sphere_vertices - 300; v < sphere_vertices; ++v)
    for (const FaceHandle f : mesh.vf_range(VertexHandle(static_cast<int>(v))))
      at_last.push_back(f);
  for (const FaceHandle f : at_last)
    if (!mesh.status(f).deleted()) mesh.delete_face(f, true);
  EXPECT_TRUE(drop_deleted_tail(mesh));
  ASSERT_LE(mesh.n_vertices(), sphere_vertices - 300);
  reach.cut_back(mesh.n_vertices(), mesh.n_faces());
  EXPECT_LE(reach.grid_below, mesh.n_vertices());
  EXPECT_LE(reach.blocks_below, mesh.n_vertices());
  // What is left is a mesh OpenMesh can work on: its boundary loop is closed and new faces link.
  for (const HalfedgeHandle h : mesh.halfedges()) {
    if (mesh.status(mesh.edge_handle(h)).deleted()) continue;
    ASSERT_LT(mesh.next_halfedge_handle(h).idx(), static_cast<int>(mesh.n_halfedges()));
    ASSERT_LT(mesh.to_vertex_handle(h).idx(), static_cast<int>(mesh.n_vertices()));
  }
  auto [last, last_points] = add_fan(Vec3(0.3, 0.2, -1.2));
  for (const FaceHandle f : last) ASSERT_TRUE(f.is_valid());
  check(last_points, "after a fill in the sphere's slots");
  file_grid();
  check(last_points, "with the grid filed again");
}

// Faces an edit adds or changes in place (flips, splits) outside a fill are noted on a kept
// reach with note_reshaped: the long ones are listed once, with their boxes as they are now, and
// the searches find what a scan finds.
TEST(MeshIntersections, SearchReachNotesReshapedFaces) {
  Mesh mesh = build_mesh(testing::uv_sphere(1, 64, 36)).mesh;
  SearchReach reach = make_search_reach(mesh);
  const auto scan = [&](const Box3& box) { return faces_meeting_by_scan(mesh, box); };
  const auto searched = [&](const Box3& box) { return faces_found(mesh, box, reach); };
  // A strip of new faces off the sphere, every other one long.
  std::vector<VertexHandle> low, high;
  for (int k = 0; k < 12; ++k) {
    low.push_back(mesh.add_vertex(Vec3(1.2 + 0.02 * k, 0, 0)));
    high.push_back(mesh.add_vertex(Vec3(1.2 + 0.02 * k, 0.02 + (k % 2) * 0.8, 0.1)));
  }
  std::vector<FaceHandle> strip;
  for (int k = 0; k + 1 < 12; ++k) {
    strip.push_back(mesh.add_face(low[k], low[k + 1], high[k + 1]));
    strip.push_back(mesh.add_face(low[k], high[k + 1], high[k]));
  }
  const std::size_t listed = reach.long_faces.size();
  reach.note_reshaped(mesh, strip);
  EXPECT_GT(reach.long_faces.size(), listed);
  const std::size_t after_strip = reach.long_faces.size();
  reach.note_reshaped(mesh, strip);  // again: nothing listed twice
  EXPECT_EQ(reach.long_faces.size(), after_strip);
  // Flip the strip's inner edges: the faces change corners in place.
  for (int k = 0; k + 1 < 12; ++k) {
    const HalfedgeHandle h = mesh.find_halfedge(low[k], high[k + 1]);
    ASSERT_TRUE(h.is_valid());
    ASSERT_TRUE(mesh.is_flip_ok(mesh.edge_handle(h)));
    mesh.flip(mesh.edge_handle(h));
  }
  reach.note_reshaped(mesh, strip);
  // Split a long edge at a point far off it: the faces beside it take that corner in place.
  const HalfedgeHandle tall = mesh.find_halfedge(low[3], high[3]);
  ASSERT_TRUE(tall.is_valid());
  const Vec3 off = 0.5 * (mesh.point(low[3]) + mesh.point(high[3])) + Vec3(0, 0, 0.7);
  const VertexHandle apex = mesh.add_vertex(off);
  mesh.split(mesh.edge_handle(tall), apex);
  std::vector<FaceHandle> around(mesh.vf_range(apex).begin(), mesh.vf_range(apex).end());
  reach.note_reshaped(mesh, around);
  std::vector<FaceHandle> listed_faces = reach.long_faces;
  std::sort(listed_faces.begin(), listed_faces.end());
  EXPECT_EQ(std::adjacent_find(listed_faces.begin(), listed_faces.end()), listed_faces.end());
  std::mt19937 random(9);
  std::uniform_real_distribution<> unit(-1, 1);
  for (int i = 0; i < 300; ++i) {
    const Vec3 c = i < 100   ? Vec3(1.2 + 0.25 * (unit(random) + 1), 0.4 * (unit(random) + 1), 0.1)
                   : i < 200 ? off + 0.3 * Vec3(unit(random), unit(random), unit(random))
                             : Vec3(unit(random) * 1.3, unit(random) * 1.3, unit(random) * 1.3);
    const Box3 box = box_around(c, 0.002 * (1 + i % 20));
    ASSERT_EQ(searched(box), scan(box)) << "box " << i;
  }
}

// The reach's grid of vertices and list of long faces must find exactly what a scan of every face
// finds: on a mesh large enough to get a grid (filed by the searches once they have scanned the
// mesh a few times), with long faces beside fine ones, and after new vertices and faces were
// added (as a fill adds them).
TEST(MeshIntersections, SearchReachFindsWhatAScanOfEveryFaceFinds) {
  MeshSoup soup = testing::uv_sphere(1, 128, 72);  // fine: > 8,192 vertices
  const auto offset = static_cast<std::uint32_t>(soup.points.size());
  const auto first_cube_face = static_cast<int>(soup.triangles.size());
  for (const Vec3& p : testing::cube(1).points) soup.points.push_back(p * 1.5 + Vec3(-0.2, 0, 0));
  for (const auto& t : testing::cube(1).triangles)  // long faces, through the sphere
    soup.triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
  Mesh mesh = build_mesh(soup).mesh;
  SearchReach reach = make_search_reach(mesh);
  ASSERT_GT(reach.grid_below, 0u);
  EXPECT_TRUE(reach.grid.empty());  // not filed before the searches have scanned enough
  ASSERT_FALSE(reach.long_faces.empty());
  EXPECT_LT(reach.longest_edge, max_edge_length(mesh));

  // Vertices and faces added after the grid was built, as a fill adds them: a long face and a
  // short one, off the cube.
  const VertexHandle apex = mesh.add_vertex(Vec3(1.6, 0.1, 0.1));
  std::vector<FaceHandle> added;
  added.push_back(mesh.add_face(apex, mesh.add_vertex(Vec3(1.7, 0.9, 0.1)),
                                mesh.add_vertex(Vec3(1.6, 0.1, 0.9))));
  added.push_back(mesh.add_face(apex, mesh.add_vertex(Vec3(1.6, 0.1, 0.08)),
                                mesh.add_vertex(Vec3(1.62, 0.1, 0.1))));
  reach.add(mesh, added);
  ASSERT_EQ(reach.long_faces.back(), added[0]);  // the short one is found through its corners

  const auto scan = [&](const Box3& box) { return faces_meeting_by_scan(mesh, box); };
  const auto searched = [&](const Box3& box) { return faces_found(mesh, box, reach); };
  std::size_t nonempty = 0;
  // First by scans passing over the runs of vertices whose boxes miss (the added vertices are
  // past the last run, which is not full; no grid), then with the grid, filed at the first
  // search it serves as if the searches had read as much as filing costs.
  const std::size_t grid_below = reach.grid_below;
  for (int pass = 0; pass < 2; ++pass) {
    reach.grid_below = pass == 0 ? 0 : grid_below;
    if (pass == 1) {
      EXPECT_TRUE(reach.grid.empty());
      reach.scanned = SearchReach::kScansBeforeFiling * reach.grid_below;
    }
    for (int i = 0; i < 200; ++i) {
      // Boxes from a point's size to the whole mesh, all over it.
      const double size = 0.002 * std::pow(1.04, i);
      const Vec3 c(std::sin(1.7 * i) * 1.2, std::cos(2.3 * i) * 1.2, std::sin(0.9 * i + 1) * 1.2);
      const Box3 box(Eigen::Vector3d(c[0] - size, c[1] - size, c[2] - size),
                     Eigen::Vector3d(c[0] + size, c[1] + size, c[2] + size));
      const std::vector<int> expected = scan(box);
      nonempty += expected.empty() ? 0 : 1;
      ASSERT_EQ(searched(box), expected) << "pass " << pass << ", box " << i;
    }
  }
  EXPECT_GT(nonempty, 120u);         // most boxes meet faces
  EXPECT_FALSE(reach.grid.empty());  // filed along the way
  ASSERT_NE(reach.blocks_below % SearchReach::kVertexBlock, 0u);
  const Box3 at_long_face(Eigen::Vector3d(1.65, 0.4, 0.4), Eigen::Vector3d(1.66, 0.41, 0.41));
  EXPECT_EQ(searched(at_long_face), std::vector<int>{added[0].idx()});
  const Box3 at_short_face(Eigen::Vector3d(1.605, 0.09, 0.09), Eigen::Vector3d(1.61, 0.11, 0.095));
  EXPECT_EQ(searched(at_short_face), std::vector<int>{added[1].idx()});

  // The same intersecting pairs as with the plain reach (the cube cuts through the sphere).
  std::vector<FaceHandle> cube_faces;
  for (const FaceHandle f : mesh.faces())
    if (f.idx() >= first_cube_face && f.idx() < static_cast<int>(soup.triangles.size()))
      cube_faces.push_back(f);
  const auto pairs = [](std::vector<std::pair<FaceHandle, FaceHandle>> found) {
    std::vector<std::pair<int, int>> out;
    for (const auto& [a, b] : found)
      out.emplace_back(std::min(a.idx(), b.idx()), std::max(a.idx(), b.idx()));
    std::sort(out.begin(), out.end());
    return out;
  };
  const auto with_grid = pairs(find_face_intersections(mesh, cube_faces, 0, reach));
  EXPECT_FALSE(with_grid.empty());
  EXPECT_EQ(with_grid, pairs(find_face_intersections(mesh, cube_faces, 0, max_edge_length(mesh))));
}

// A search lists what it finds in the same order with the grid, with the runs of vertices passed
// over by their boxes, and by a scan of every vertex (the order a fill's first crossing found
// depends on, and with it the fill): whether and when the searches filed the vertices, and which
// runs they skipped, changes no result.
TEST(MeshIntersections, TheGridChangesNoSearchsOrder) {
  Mesh mesh = build_mesh(testing::uv_sphere(1, 128, 72)).mesh;
  SearchReach gridded = make_search_reach(mesh);
  gridded.scanned = SearchReach::kScansBeforeFiling * gridded.grid_below;  // filed at once
  const SearchReach scanning = make_search_reach(mesh, /*with_grid=*/false);
  SearchReach every_vertex = make_search_reach(mesh, /*with_grid=*/false);
  every_vertex.blocks_below = 0;
  ASSERT_GT(gridded.grid_below, 0u);
  ASSERT_EQ(scanning.grid_below, 0u);
  ASSERT_GT(scanning.blocks_below, 0u);
  const auto listed = [&](const Box3& box, const SearchReach& reach) {
    std::vector<int> out;
    for (const FaceHandle f : faces_in_box(mesh, box, reach)) out.push_back(f.idx());
    return out;
  };
  std::size_t compared = 0;
  for (int i = 0; i < 60; ++i) {
    // Boxes from about an edge to a fifth of the sphere's radius, centred on its surface.
    const double size = 0.01 * std::pow(1.05, i);
    const Vec3 c = Vec3(std::sin(1.3 * i), std::cos(0.7 * i), std::sin(2.1 * i + 0.5)).normalized();
    const Box3 box(Eigen::Vector3d(c[0] - size, c[1] - size, c[2] - size),
                   Eigen::Vector3d(c[0] + size, c[1] + size, c[2] + size));
    const std::vector<int> by_scan = listed(box, every_vertex);
    ASSERT_EQ(listed(box, gridded), by_scan) << "box " << i;
    ASSERT_EQ(listed(box, scanning), by_scan) << "box " << i;
    compared += by_scan.size() > 1 ? 1 : 0;
  }
  EXPECT_FALSE(gridded.grid.empty());  // the later searches went through the grid
  EXPECT_GT(compared, 50u);
}

}  // namespace
}  // namespace touchmend::geometry
