#include "server/geometry/mesh_intersections.h"

#include <unordered_set>

#include "server/geometry/bvh.h"
#include "server/geometry/intersection.h"

namespace touchmend::geometry {
namespace {

void face_data(const Mesh& mesh, FaceHandle f, TrianglePoints& t, std::array<int, 3>& ids) {
  int k = 0;
  for (const VertexHandle v : mesh.fv_range(f)) {
    t[static_cast<std::size_t>(k)] = mesh.point(v);
    ids[static_cast<std::size_t>(k)] = v.idx();
    ++k;
  }
}

}  // namespace

std::vector<std::pair<FaceHandle, FaceHandle>> find_face_intersections(const Mesh& mesh,
                                                                      std::span<const FaceHandle> faces,
                                                                      std::size_t stop_after) {
  std::vector<std::pair<FaceHandle, FaceHandle>> out;
  if (faces.empty()) return out;
  std::unordered_set<int> chosen;
  Box3 region;
  for (const FaceHandle f : faces) {
    chosen.insert(f.idx());
    TrianglePoints t;
    std::array<int, 3> ids;
    face_data(mesh, f, t, ids);
    region.extend(triangle_box(t));
  }
  const double pad = 1e-9 * std::max(region.diagonal().norm(), 1e-300);
  region.min().array() -= pad;
  region.max().array() += pad;
  // Candidates: every face whose box meets the region (one linear scan; cheaper than a
  // whole-mesh tree for one patch).
  std::vector<FaceHandle> candidates;
  std::vector<TrianglePoints> triangles;
  std::vector<std::array<int, 3>> candidate_ids;
  for (const FaceHandle f : mesh.faces()) {
    TrianglePoints t;
    std::array<int, 3> ids;
    face_data(mesh, f, t, ids);
    if (!triangle_box(t).intersects(region)) continue;
    candidates.push_back(f);
    triangles.push_back(t);
    candidate_ids.push_back(ids);
  }
  const TriangleBvh bvh(triangles);
  for (const FaceHandle f : faces) {
    TrianglePoints t;
    std::array<int, 3> ids;
    face_data(mesh, f, t, ids);
    bool stop = false;
    bvh.query_box(triangle_box(t), [&](std::uint32_t c) {
      if (stop) return;
      const FaceHandle g = candidates[c];
      if (g == f) return;
      if (chosen.count(g.idx()) && g.idx() < f.idx()) return;  // chosen pair: test once
      if (triangles_intersect(t, ids, triangles[c], candidate_ids[c])) {
        out.emplace_back(f, g);
        if (stop_after && out.size() >= stop_after) stop = true;
      }
    });
    if (stop) break;
  }
  return out;
}

std::vector<std::pair<FaceHandle, FaceHandle>> find_self_intersections(const Mesh& mesh,
                                                                      std::size_t stop_after) {
  std::vector<FaceHandle> all(mesh.faces().begin(), mesh.faces().end());
  return find_face_intersections(mesh, all, stop_after);
}

}  // namespace touchmend::geometry
