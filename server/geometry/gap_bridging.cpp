#include "server/geometry/gap_bridging.h"

#include <algorithm>

#include <fmt/format.h>

#include "server/geometry/holes.h"
#include "server/geometry/intersection.h"
#include "server/geometry/mesh_intersections.h"

namespace touchmend::geometry {
namespace {

StitchResult refuse(std::string why) {
  StitchResult r;
  r.reason = std::move(why);
  return r;
}

Vec3 vertex_normal(const Mesh& mesh, VertexHandle v) {
  Vec3 sum(0, 0, 0);
  for (const FaceHandle f : mesh.vf_range(v)) sum += mesh.calc_face_normal(f);
  const double len = sum.norm();
  return len > 0 ? sum / len : sum;
}

}  // namespace

StitchResult stitch_triangle(Mesh& mesh, VertexHandle a, VertexHandle b, VertexHandle t,
                             const StitchOptions& options) {
  const auto valid = [&](VertexHandle v) {
    return v.is_valid() && static_cast<std::size_t>(v.idx()) < mesh.n_vertices() &&
           !mesh.status(v).deleted();
  };
  if (!valid(a) || !valid(b) || !valid(t)) return refuse("a vertex does not exist");
  if (t == a || t == b || a == b) return refuse("the three vertices must be different");
  // The boundary edge and its free direction: the new face takes the direction no face uses,
  // so it is oriented like the face it joins (ALGORITHMS.md §4.1).
  HalfedgeHandle free;
  for (const HalfedgeHandle h : {mesh.find_halfedge(a, b), mesh.find_halfedge(b, a)}) {
    if (h.is_valid() && mesh.is_boundary(h) && !mesh.is_boundary(mesh.opposite_halfedge_handle(h)))
      free = h;
  }
  if (!free.is_valid())
    return refuse(fmt::format("{}-{} is not a boundary edge of the mesh", a.idx(), b.idx()));
  if (!mesh.is_boundary(t))
    return refuse(
        fmt::format("vertex {} is not on a boundary (stitches end on a boundary vertex)", t.idx()));
  const VertexHandle from = mesh.from_vertex_handle(free), to = mesh.to_vertex_handle(free);
  // The other two edges must be new, or boundary edges used in their free direction.
  for (const auto& [x, y] : {std::pair{to, t}, std::pair{t, from}}) {
    const HalfedgeHandle h = mesh.find_halfedge(x, y);
    if (h.is_valid() && !mesh.is_boundary(h))
      return refuse(
          fmt::format("edge {}-{} already has a face on this side: the result would be "
                      "non-manifold",
                      x.idx(), y.idx()));
  }
  const Vec3 p0 = mesh.point(from), p1 = mesh.point(to), p2 = mesh.point(t);
  const Vec3 cross = OpenMesh::cross(p1 - p0, p2 - p0);
  const double longest = std::max({(p1 - p0).sqrnorm(), (p2 - p1).sqrnorm(), (p0 - p2).sqrnorm()});
  if (!(cross.norm() > 1e-10 * longest)) return refuse("the triangle would be degenerate");
  const Vec3 normal = cross / cross.norm();
  const Vec3 joined = mesh.calc_face_normal(mesh.face_handle(mesh.opposite_halfedge_handle(free)));
  const Vec3 at_t = vertex_normal(mesh, t);
  // Opposite orientations: the stitch opposes both sides (ALGORITHMS.md §4.1), or the target
  // surface faces strongly away from it (more than 120°): one surface has to be flipped.
  if ((OpenMesh::dot(normal, joined) < 0 && OpenMesh::dot(normal, at_t) < 0) ||
      OpenMesh::dot(normal, at_t) < -0.5)
    return refuse("the surfaces have opposite orientations: flip one before bridging");
  if (options.check_intersections) {
    const TrianglePoints tri{p0, p1, p2};
    const std::array<int, 3> ids{from.idx(), to.idx(), t.idx()};
    Eigen::AlignedBox3d box;
    for (const Vec3& p : tri) box.extend(Eigen::Vector3d(p[0], p[1], p[2]));
    for (const FaceHandle f : faces_in_box(mesh, box, max_edge_length(mesh))) {
      TrianglePoints other;
      std::array<int, 3> other_ids{};
      int k = 0;
      for (const VertexHandle v : mesh.fv_range(f)) {
        other[static_cast<std::size_t>(k)] = mesh.point(v);
        other_ids[static_cast<std::size_t>(k++)] = v.idx();
      }
      if (triangles_intersect(tri, ids, other, other_ids))
        return refuse(fmt::format("the triangle would intersect face {}", f.idx()));
    }
  }
  const FaceHandle face = mesh.add_face(from, to, t);
  if (!face.is_valid())
    return refuse("the mesh cannot take this face there (it would make a complex vertex)");
  StitchResult r;
  r.ok = true;
  r.face = face;
  return r;
}

GapBridgeResult bridge_gap(Mesh& mesh, const GapEnd& first, const GapEnd& second,
                           const FillOptions& fill, const StitchOptions& stitch) {
  GapBridgeResult result;
  const StitchResult one = stitch_triangle(mesh, first.a, first.b, first.t, stitch);
  if (!one.ok) {
    result.reason = "first end: " + one.reason;
    return result;
  }
  const StitchResult two = stitch_triangle(mesh, second.a, second.b, second.t, stitch);
  if (!two.ok) {
    mesh.delete_face(one.face, false);  // refused as a whole: take the first stitch back
    result.reason = "second end: " + two.reason;
    return result;
  }
  result.stitches = {one.face, two.face};
  // The gap is now a closed loop through a boundary edge of each stitch. Each stitch also has
  // an edge on the outer boundary; of the loops touching both stitches the gap is the
  // shorter one (ALGORITHMS.md §4.2 leaves the choice open).
  const auto touches = [&](const Hole& hole, FaceHandle f) {
    return std::any_of(hole.halfedges.begin(), hole.halfedges.end(), [&](HalfedgeHandle h) {
      return mesh.face_handle(mesh.opposite_halfedge_handle(h)) == f;
    });
  };
  HoleSearchResult holes = find_holes(mesh);
  const Hole* gap = nullptr;
  for (const Hole& hole : holes.holes) {
    if (!touches(hole, one.face) || !touches(hole, two.face)) continue;
    if (!gap || hole.perimeter < gap->perimeter) gap = &hole;
  }
  if (!gap) {
    result.ok = true;  // the stitches closed it already (a gap of one triangle's width)
    return result;
  }
  HoleFillReport report = fill_hole(mesh, *gap, fill);
  const bool filled = report.filled;
  if (!filled) result.reason = "the gap loop could not be filled: " + report.reason;
  result.fills.push_back(std::move(report));
  result.ok = filled;
  return result;
}

}  // namespace touchmend::geometry
