#include "tests/support/invariants.h"

#include <fmt/format.h>

#include "server/geometry/mesh_intersections.h"
#include "server/geometry/metrics.h"

namespace touchmend::testing {

HalfedgeSet boundary_halfedges(const geometry::Mesh& mesh) {
  HalfedgeSet out;
  for (const auto h : mesh.halfedges())
    if (mesh.is_boundary(h))
      out.emplace(mesh.from_vertex_handle(h).idx(), mesh.to_vertex_handle(h).idx());
  return out;
}

Snapshot take_snapshot(const geometry::Mesh& mesh) {
  Snapshot s;
  s.boundary = boundary_halfedges(mesh);
  for (const auto v : mesh.vertices()) s.points.push_back(mesh.point(v));
  s.non_manifold_vertices = geometry::validate_mesh(mesh).non_manifold_vertices;
  return s;
}

std::string check_fill_invariants(const Snapshot& before, const geometry::Mesh& after,
                                  const std::vector<geometry::HoleFillReport>& reports,
                                  const std::vector<geometry::Hole>& holes_before) {
  std::string problems;
  HalfedgeSet expected = before.boundary;
  for (const auto& r : reports) {
    // A removed fragment takes its loop with it, as a fill does.
    if (!r.filled && !r.fragment_removed()) continue;
    const geometry::Hole* hole = nullptr;
    for (const auto& h : holes_before)
      if (h.id == r.hole_id) hole = &h;
    if (!hole) {
      problems += fmt::format("report for unknown hole {}; ", r.hole_id);
      continue;
    }
    for (std::size_t i = 0; i < hole->loop.size(); ++i)
      expected.erase({hole->loop[i].idx(), hole->loop[(i + 1) % hole->loop.size()].idx()});
  }
  const HalfedgeSet actual = boundary_halfedges(after);
  if (actual != expected)
    problems += fmt::format("boundary differs: {} halfedges expected, {} found; ", expected.size(),
                            actual.size());
  for (std::size_t i = 0; i < before.points.size(); ++i)
    if (after.point(geometry::VertexHandle(static_cast<int>(i))) != before.points[i]) {
      problems += fmt::format("original vertex {} moved; ", i);
      break;
    }
  const geometry::ValidationReport v = geometry::validate_mesh(after);
  if (v.non_manifold_edges)
    problems += fmt::format("{} non-manifold edges; ", v.non_manifold_edges);
  if (v.inconsistent_edges)
    problems += fmt::format("{} inconsistently oriented edges; ", v.inconsistent_edges);
  if (v.non_manifold_vertices > before.non_manifold_vertices)
    problems += fmt::format("non-manifold vertices grew from {} to {}; ",
                            before.non_manifold_vertices, v.non_manifold_vertices);
  if (!v.refused_faces.empty())
    problems += fmt::format("{} faces cannot be rebuilt; ", v.refused_faces.size());
  std::vector<geometry::FaceHandle> added;
  for (const auto& r : reports) added.insert(added.end(), r.new_faces.begin(), r.new_faces.end());
  // No degenerate new triangle (quality bounds proper are asserted per test).
  const geometry::TriangleQuality quality =
      geometry::triangle_quality(geometry::face_triangles(after, added));
  if (!added.empty() && !(quality.min_angle_deg > 0.05))
    problems += fmt::format("a new face has a {:.3f} deg angle; ", quality.min_angle_deg);
  const auto hits = geometry::find_face_intersections(after, added, 5);
  if (!hits.empty())
    problems += fmt::format("{}+ intersecting face pairs involve new faces; ", hits.size());
  return problems;
}

}  // namespace touchmend::testing
