#include "tests/bench/cgal_reference.h"

#include <chrono>
#include <set>

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/triangulate_hole.h>
#include <CGAL/Surface_mesh.h>

namespace touchmend::bench {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using SurfaceMesh = CGAL::Surface_mesh<Kernel::Point_3>;
namespace PMP = CGAL::Polygon_mesh_processing;

std::vector<CgalHoleResult> cgal_fill_holes(const geometry::MeshSoup& soup,
                                            const std::vector<std::vector<std::uint32_t>>& loops,
                                            CgalMode mode) {
  SurfaceMesh mesh;
  std::vector<SurfaceMesh::Vertex_index> vi;
  for (const auto& p : soup.points)
    vi.push_back(mesh.add_vertex(Kernel::Point_3(p[0], p[1], p[2])));
  for (const auto& t : soup.triangles) mesh.add_face(vi[t[0]], vi[t[1]], vi[t[2]]);
  std::vector<CgalHoleResult> out;
  for (const auto& loop : loops) {
    CgalHoleResult r;
    const std::set<std::uint32_t> wanted(loop.begin(), loop.end());
    SurfaceMesh::Halfedge_index border;
    for (const auto h : mesh.halfedges())
      if (mesh.is_border(h) && wanted.count(static_cast<std::uint32_t>(mesh.source(h).idx())) &&
          wanted.count(static_cast<std::uint32_t>(mesh.target(h).idx()))) {
        border = h;
        break;
      }
    if (border == SurfaceMesh::null_halfedge()) {
      out.push_back(r);
      continue;
    }
    std::vector<SurfaceMesh::Face_index> faces;
    std::vector<SurfaceMesh::Vertex_index> vertices;
    const auto start = std::chrono::steady_clock::now();
    bool ok = true;
    if (mode == CgalMode::RefineAndFair) {
      ok = std::get<0>(PMP::triangulate_refine_and_fair_hole(
          mesh, border, std::back_inserter(faces), std::back_inserter(vertices)));
    } else {
      PMP::triangulate_hole(mesh, border, std::back_inserter(faces));
    }
    r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    r.ok = ok && !faces.empty();
    for (const auto f : faces) {
      geometry::TrianglePoints t;
      int k = 0;
      for (const auto v : CGAL::vertices_around_face(mesh.halfedge(f), mesh)) {
        const auto& p = mesh.point(v);
        t[static_cast<std::size_t>(k++)] = geometry::Vec3(p.x(), p.y(), p.z());
      }
      r.new_triangles.push_back(t);
    }
    out.push_back(std::move(r));
  }
  return out;
}

}  // namespace touchmend::bench
