#include "server/geometry/mesh_intersections.h"

#include <algorithm>
#include <cmath>
#include <unordered_set>

#include "server/geometry/bvh.h"
#include "server/geometry/intersection.h"
#include "server/geometry/local_map.h"
#include "server/geometry/projection.h"

namespace touchmend::geometry {
namespace {

//! The face of outgoing halfedge \p h (corners from(h), to(h), to(next(h)), in the face's
//! order) into \p t and \p ids, if from(h) is its corner of lowest index inside \p box: the
//! vertex scans meet every face once per corner inside the box and handle it at that one only,
//! with no set of faces seen. False for a boundary halfedge.
bool face_from_lowest_inside(const Mesh& mesh, HalfedgeHandle h, const Box3& box, TrianglePoints& t,
                             std::array<int, 3>& ids) {
  if (mesh.is_boundary(h)) return false;
  const VertexHandle a = mesh.from_vertex_handle(h), b = mesh.to_vertex_handle(h),
                     c = mesh.to_vertex_handle(mesh.next_halfedge_handle(h));
  t = {mesh.point(a), mesh.point(b), mesh.point(c)};
  ids = {a.idx(), b.idx(), c.idx()};
  const auto inside = [&](const Vec3& p) {
    return box.contains(Eigen::Vector3d(p[0], p[1], p[2]));
  };
  if (b.idx() < a.idx() && inside(t[1])) return false;
  if (c.idx() < a.idx() && inside(t[2])) return false;
  return true;
}

//! Calls visit(face, triangle, corner ids) once for every non-deleted face that may meet \p box:
//! those with a corner within the reach's longest edge of it (only at points that pass
//! \p keep_point, a cheaper test the caller may narrow the search with), and the reach's long
//! faces. The callers test the boxes themselves.
template <typename KeepPoint, typename Visit>
void for_each_face_near(const Mesh& mesh, const Box3& box, const SearchReach& reach,
                        KeepPoint&& keep_point, Visit&& visit) {
  Box3 grown = box;
  grown.min().array() -= reach.longest_edge;
  grown.max().array() += reach.longest_edge;
  LocalSet long_faces(reach.long_faces.size() + 16);
  for (const FaceHandle f : reach.long_faces) long_faces.insert(f.idx());
  for (const VertexHandle v : mesh.vertices()) {
    const Vec3& p = mesh.point(v);
    const Eigen::Vector3d q(p[0], p[1], p[2]);
    if (!grown.contains(q) || !keep_point(q)) continue;
    for (const HalfedgeHandle h : mesh.voh_range(v)) {
      TrianglePoints t;
      std::array<int, 3> ids;
      if (!face_from_lowest_inside(mesh, h, grown, t, ids)) continue;
      const FaceHandle g = mesh.face_handle(h);
      if (long_faces.contains(g.idx())) continue;  // visited below
      if (!visit(g, t, ids)) return;
    }
  }
  for (const FaceHandle g : reach.long_faces) {
    if (!g.is_valid() || static_cast<std::size_t>(g.idx()) >= mesh.n_faces() ||
        mesh.status(g).deleted())
      continue;
    TrianglePoints t;
    std::array<int, 3> ids;
    face_corners(mesh, g, t, ids);
    if (!visit(g, t, ids)) return;
  }
}

}  // namespace

void SearchReach::add(const Mesh& mesh, std::span<const FaceHandle> faces) {
  for (const FaceHandle f : faces) {
    double longest = 0;
    for (const HalfedgeHandle h : mesh.fh_range(f))
      longest = std::max(longest, mesh.calc_edge_length(h));
    if (longest > longest_edge) long_faces.push_back(f);
  }
}

double max_edge_length(const Mesh& mesh) {
  double longest = 0;
  for (const EdgeHandle e : mesh.edges()) longest = std::max(longest, mesh.calc_edge_sqr_length(e));
  return std::sqrt(longest);
}

std::vector<FaceHandle> faces_in_box(const Mesh& mesh, const Box3& box, double longest_edge) {
  return faces_in_box(mesh, box, SearchReach{longest_edge, {}});
}

std::vector<FaceHandle> faces_in_box(const Mesh& mesh, const Box3& box, const SearchReach& reach) {
  std::vector<FaceHandle> out;
  for_each_face_near(
      mesh, box, reach, [](const Eigen::Vector3d&) { return true; },
      [&](FaceHandle f, const TrianglePoints& t, const std::array<int, 3>&) {
        if (triangle_box(t).intersects(box)) out.push_back(f);
        return true;
      });
  return out;
}

namespace {

//! The chosen faces against every face near them: one scan of the points within the longest
//! edge of the chosen faces' box (every face meeting the box has a corner there), each nearby
//! face's box looked up in a tree of the chosen triangles. The chosen set is usually a patch,
//! small next to the mesh, so the tree is built over it, not over the neighbourhood.
std::vector<std::pair<FaceHandle, FaceHandle>> intersections_of(const Mesh& mesh,
                                                                std::span<const FaceHandle> faces,
                                                                std::size_t stop_after,
                                                                const SearchReach& reach,
                                                                bool test_within) {
  std::vector<std::pair<FaceHandle, FaceHandle>> out;
  if (faces.empty()) return out;
  std::vector<TrianglePoints> triangles(faces.size());
  std::vector<std::array<int, 3>> ids(faces.size());
  LocalSet chosen(faces.size() + 16);
  Box3 region;
  for (std::size_t i = 0; i < faces.size(); ++i) {
    chosen.insert(faces[i].idx());
    face_corners(mesh, faces[i], triangles[i], ids[i]);
    region.extend(triangle_box(triangles[i]));
  }
  const double pad = 1e-9 * std::max(region.diagonal().norm(), 1e-300);
  region.min().array() -= pad;
  region.max().array() += pad;
  const TriangleBvh tree(triangles);
  const auto full = [&] { return stop_after != 0 && out.size() >= stop_after; };
  // Against the rest of the mesh. A face near the patch has every corner within the longest
  // edge of some patch triangle's box: a point farther from all of them (most of a large box
  // around a curved patch) is passed over without reading its faces.
  const double reach_edge = reach.longest_edge;
  for_each_face_near(
      mesh, region, reach,
      [&](const Eigen::Vector3d& q) {
        return tree.overlaps_any(Box3(q.array() - reach_edge, q.array() + reach_edge));
      },
      [&](FaceHandle g, const TrianglePoints& t, const std::array<int, 3>& g_ids) {
        if (chosen.contains(g.idx())) return true;
        const Box3 box = triangle_box(t);
        if (!box.intersects(region)) return true;
        tree.query_box(box, [&](std::uint32_t c) {
          if (full()) return;
          if (triangles_intersect(triangles[c], ids[c], t, g_ids)) out.emplace_back(faces[c], g);
        });
        return !full();
      });
  if (!test_within || full()) return out;
  // Among the chosen faces themselves, each pair once.
  for (std::size_t i = 0; i < faces.size() && !full(); ++i)
    tree.query_box(triangle_box(triangles[i]), [&](std::uint32_t j) {
      if (full() || j <= i) return;
      if (triangles_intersect(triangles[i], ids[i], triangles[j], ids[j]))
        out.emplace_back(faces[i], faces[j]);
    });
  return out;
}

}  // namespace

std::vector<std::size_t> triangles_crossing_mesh(const Mesh& mesh,
                                                 std::span<const TrianglePoints> triangles,
                                                 std::span<const std::array<int, 3>> ids,
                                                 const SearchReach& reach) {
  std::vector<std::size_t> out;
  if (triangles.empty()) return out;
  Box3 region;
  for (const TrianglePoints& t : triangles) region.extend(triangle_box(t));
  const TriangleBvh tree(std::vector<TrianglePoints>(triangles.begin(), triangles.end()));
  std::vector<char> crossing(triangles.size(), 0);
  const double reach_edge = reach.longest_edge;
  for_each_face_near(
      mesh, region, reach,
      [&](const Eigen::Vector3d& q) {
        return tree.overlaps_any(Box3(q.array() - reach_edge, q.array() + reach_edge));
      },
      [&](FaceHandle, const TrianglePoints& t, const std::array<int, 3>& g_ids) {
        tree.query_box(triangle_box(t), [&](std::uint32_t c) {
          if (!crossing[c] && triangles_intersect(triangles[c], ids[c], t, g_ids)) crossing[c] = 1;
        });
        return true;
      });
  for (std::size_t c = 0; c < triangles.size(); ++c)
    if (crossing[c]) out.push_back(c);
  return out;
}

namespace {
SearchReach reach_of(const Mesh& mesh, double longest_edge) {
  return SearchReach{longest_edge > 0 ? longest_edge : max_edge_length(mesh), {}};
}
}  // namespace

std::vector<std::pair<FaceHandle, FaceHandle>> find_face_intersections(
    const Mesh& mesh, std::span<const FaceHandle> faces, std::size_t stop_after,
    double longest_edge) {
  return intersections_of(mesh, faces, stop_after, reach_of(mesh, longest_edge), true);
}

std::vector<std::pair<FaceHandle, FaceHandle>> find_face_intersections(
    const Mesh& mesh, std::span<const FaceHandle> faces, std::size_t stop_after,
    const SearchReach& reach) {
  return intersections_of(mesh, faces, stop_after, reach, true);
}

std::vector<std::pair<FaceHandle, FaceHandle>> find_intersections_with_rest(
    const Mesh& mesh, std::span<const FaceHandle> faces, std::size_t stop_after,
    double longest_edge) {
  return intersections_of(mesh, faces, stop_after, reach_of(mesh, longest_edge), false);
}

std::vector<std::pair<FaceHandle, FaceHandle>> find_intersections_with_rest(
    const Mesh& mesh, std::span<const FaceHandle> faces, std::size_t stop_after,
    const SearchReach& reach) {
  return intersections_of(mesh, faces, stop_after, reach, false);
}

bool projects_injectively(const Mesh& mesh, std::span<const FaceHandle> faces,
                          const ReferenceFrame& frame) {
  // Degree argument: when the patch is a disk whose boundary projects onto a simple polygon,
  // the number of patch triangles covering a generic point of the plane, each counted with
  // the sign of its projected orientation, is the boundary's winding number there (0 or 1).
  // With every triangle of one strict sign no point is covered twice, so the patch is the
  // graph of a function over the polygon and no two of its triangles can meet in 3D beyond
  // their shared edges and vertices.
  double scale = 0;
  std::vector<std::array<Point2, 3>> projected;
  projected.reserve(faces.size());
  for (const FaceHandle f : faces) {
    std::array<Point2, 3> t;
    int k = 0;
    for (const VertexHandle v : mesh.fv_range(f))
      t[static_cast<std::size_t>(k++)] = frame.project(mesh.point(v));
    for (const Point2& p : t) scale = std::max({scale, std::abs(p.x()), std::abs(p.y())});
    projected.push_back(t);
  }
  const double min_area = 1e-12 * scale * scale;
  int sign = 0;
  for (const auto& t : projected) {
    const double a = orient2d(t[0], t[1], t[2]);
    if (std::abs(a) <= min_area || !std::isfinite(a)) return false;
    const int s = a > 0 ? 1 : -1;
    if (sign == 0) sign = s;
    if (s != sign) return false;
  }
  return true;
}

std::vector<std::pair<FaceHandle, FaceHandle>> find_self_intersections(const Mesh& mesh,
                                                                       std::size_t stop_after) {
  std::vector<FaceHandle> all(mesh.faces().begin(), mesh.faces().end());
  return find_face_intersections(mesh, all, stop_after);
}

}  // namespace touchmend::geometry
