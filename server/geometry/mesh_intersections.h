#pragma once

//! \file mesh_intersections.h
//! \brief Intersections between chosen faces and the rest of a mesh.

#include <array>
#include <cstddef>
#include <span>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "server/geometry/intersection.h"
#include "server/geometry/mesh.h"
#include "server/geometry/projection.h"

namespace touchmend::geometry {

//! The corner points of face \p f and their vertex indices (the ids triangles_intersect
//! compares), in the face's order.
inline void face_corners(const Mesh& mesh, FaceHandle f, TrianglePoints& points,
                         std::array<int, 3>& ids) {
  std::size_t k = 0;
  for (const VertexHandle v : mesh.fv_range(f)) {
    points[k] = mesh.point(v);
    ids[k++] = v.idx();
  }
}

//! Length of the longest edge (the search radius that makes faces_in_box exact).
double max_edge_length(const Mesh& mesh);

//! How far the local searches look around a box: every face meeting it has a corner within the
//! longest edge of it, except the faces listed in long_faces, which every search tests directly.
//! A fill adds a few long triangles to a finely meshed scan (a large hole's patch is coarser than
//! the surface around it); keeping them on the list, not in longest_edge, keeps every later
//! search as local as the mesh is fine.
struct SearchReach {
  double longest_edge = 0;
  std::vector<FaceHandle> long_faces;
  //! Files \p faces, added to the mesh: on long_faces those with an edge over longest_edge.
  void add(const Mesh& mesh, std::span<const FaceHandle> faces);
};

//! Every face whose bounding box meets \p box. Found through the vertices within
//! \p longest_edge of the box (every point of a triangle lies within its longest edge of
//! each corner), which is a scan of the contiguous point array instead of all faces.
std::vector<FaceHandle> faces_in_box(const Mesh& mesh, const Eigen::AlignedBox3d& box,
                                     double longest_edge);
std::vector<FaceHandle> faces_in_box(const Mesh& mesh, const Eigen::AlignedBox3d& box,
                                     const SearchReach& reach);

//! Pairs of intersecting faces with at least one face in \p faces (each pair once). Faces
//! sharing a vertex or an edge intersect only beyond what they share (see
//! triangles_intersect). Stops after \p stop_after pairs (0: count all). \p longest_edge:
//! max_edge_length(mesh), or <= 0 to compute it here.
std::vector<std::pair<FaceHandle, FaceHandle>> find_face_intersections(
    const Mesh& mesh, std::span<const FaceHandle> faces, std::size_t stop_after = 0,
    double longest_edge = 0);
std::vector<std::pair<FaceHandle, FaceHandle>> find_face_intersections(
    const Mesh& mesh, std::span<const FaceHandle> faces, std::size_t stop_after,
    const SearchReach& reach);

//! Like find_face_intersections, but two faces that are both in \p faces are never tested
//! against each other: for a patch already known to be embedded (projects_injectively).
std::vector<std::pair<FaceHandle, FaceHandle>> find_intersections_with_rest(
    const Mesh& mesh, std::span<const FaceHandle> faces, std::size_t stop_after = 0,
    double longest_edge = 0);
std::vector<std::pair<FaceHandle, FaceHandle>> find_intersections_with_rest(
    const Mesh& mesh, std::span<const FaceHandle> faces, std::size_t stop_after,
    const SearchReach& reach);

//! Which of \p triangles (not in the mesh; \p ids their corners' vertex indices in it, for the
//! shared-vertex rules of triangles_intersect) intersect a face of the mesh: indices into
//! \p triangles. One scan of the points near the triangles, like find_face_intersections.
std::vector<std::size_t> triangles_crossing_mesh(const Mesh& mesh,
                                                 std::span<const TrianglePoints> triangles,
                                                 std::span<const std::array<int, 3>> ids,
                                                 const SearchReach& reach);

//! True if every face of \p faces projects onto the plane of \p frame with the same strict
//! orientation. For a patch that is a disk whose boundary projects onto a simple polygon
//! (a simple hole in its reference frame) this proves the patch has no self-intersection.
bool projects_injectively(const Mesh& mesh, std::span<const FaceHandle> faces,
                          const ReferenceFrame& frame);

//! Every intersecting pair of faces of the whole mesh.
std::vector<std::pair<FaceHandle, FaceHandle>> find_self_intersections(const Mesh& mesh,
                                                                       std::size_t stop_after = 0);

}  // namespace touchmend::geometry
