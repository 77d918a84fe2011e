#pragma once

//! \file mesh_intersections.h
//! \brief Intersections between chosen faces and the rest of a mesh.

#include <array>
#include <cstddef>
#include <cstdint>
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

//! The mesh's vertices filed by a uniform grid of cells (hashed into buckets, so the memory is
//! linear in the vertices however large the bounding box): a search visits the cells its box
//! covers instead of every vertex. Vertices added after it was built (a fill's new vertices)
//! are not filed; the searches scan them directly.
struct VertexGrid {
  double cell = 0;  //!< 0: no grid (every search scans all vertices)
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Vector3i cells = Eigen::Vector3i::Zero();  //!< cells per axis over the filed vertices
  std::vector<std::uint32_t> bucket_start;          //!< a power of two plus one entries
  std::vector<std::uint32_t> filed;                 //!< vertex indices, ordered by bucket
  std::size_t filed_below = 0;                      //!< vertices with a smaller index were filed

  bool empty() const { return !(cell > 0); }
  //! The cell of point \p q; per axis -1 below the grid and `cells` above it (so a point far
  //! outside, or NaN, cannot overflow the conversion).
  Eigen::Vector3i cell_of(const Eigen::Vector3d& q) const;
  std::size_t bucket_of(const Eigen::Vector3i& c) const;
};

//! How far the local searches look around a box: every face meeting it has a corner within
//! longest_edge of it, except the faces listed in long_faces, which every search tests directly
//! (by their boxes, kept beside them). A face is long when one of its edges is longer than
//! longest_edge. CAD meshes mix fine triangles with long strips (couplingdown: the longest
//! edge is 12 times the median), and a fill adds a few long triangles to a finely meshed scan
//! (a large hole's patch is coarser than the surface around it); keeping those faces on the
//! list, not in longest_edge, keeps every search as local as most of the mesh is fine.
struct SearchReach {
  double longest_edge = 0;
  std::vector<FaceHandle> long_faces;
  std::vector<Eigen::AlignedBox3d> long_boxes;  //!< the boxes of long_faces, in their order
  //! Vertices below this index may be filed in a grid (0: never; make_search_reach's
  //! with_grid on a mesh of 8,192 vertices or more). They must not move while the reach is
  //! used (a fill moves only the vertices it adds).
  std::size_t grid_below = 0;
  //! Runs of kVertexBlock consecutive vertex indices below blocks_below and the box of each
  //! run's vertices: a scan passes over a run whose box misses the searched box without reading
  //! its points. The same rule as for the grid: those vertices must not move while the reach is
  //! used.
  static constexpr std::size_t kVertexBlock = 32;
  std::size_t blocks_below = 0;
  std::vector<Eigen::AlignedBox3d> block_boxes;
  //! Where those vertices are, filed by the searches once they have scanned the mesh about as
  //! often as the filing costs; no search's result depends on whether it is there. A cache
  //! kept by const searches, so a reach is used by one thread at a time (as the fills use it).
  mutable VertexGrid grid;
  //! Points (and runs' boxes) the searches read, where the grid would have served them, before
  //! the filing: the searches file the vertices once they have read kScansBeforeFiling times
  //! grid_below (filing costs about four scans: 88 us against 21 on the rocker arm's 10k
  //! vertices, 321 against 74 on the bunny's 36k). Never more than twice what the better choice
  //! would have cost; most fill calls make a few searches that read a few runs each.
  mutable std::size_t scanned = 0;
  static constexpr std::size_t kScansBeforeFiling = 4;
  //! Files \p faces, added to the mesh: on long_faces those with an edge over longest_edge.
  void add(const Mesh& mesh, std::span<const FaceHandle> faces);
  //! Keeps the reach true after vertex \p v moved (or an isolated one was placed anew) outside a
  //! fill, for a reach kept across edits (an interactive session's): its run's box grows to
  //! take its new position, a filed grid is dropped (the searches file it again), and its faces
  //! the move made long are listed.
  void note_moved(const Mesh& mesh, VertexHandle v);
  //! Keeps the reach true after \p faces were added or changed in place (an edge flip or split
  //! gives a face other corners) outside a fill: the long ones are listed once, with the boxes
  //! they have now. Their vertices must be new (past blocks_below) or noted by note_moved.
  void note_reshaped(const Mesh& mesh, std::span<const FaceHandle> faces);
  //! Boxes the vertices added since the runs were boxed (from blocks_below on), so the searches
  //! pass over them run by run instead of reading each: for a reach kept across many fills.
  //! They must not move afterwards (a fill moves only the vertices it adds, while it adds them).
  void box_new_vertices(const Mesh& mesh);
  //! Keeps the reach true after the mesh's arrays were cut back to \p n_vertices and
  //! \p n_faces (its trailing deleted elements dropped, mesh.resize): the runs and the grid end
  //! there (the indices past it will be new vertices, anywhere), the long faces past it go.
  void cut_back(std::size_t n_vertices, std::size_t n_faces);
};

//! The reach for \p mesh: longest_edge is a few times the median edge (capped by the longest
//! edge), the faces with a longer edge are listed, the vertices' runs are boxed, and, with
//! \p with_grid and a mesh of more than a few thousand vertices, the vertices may be filed in a
//! grid of cells that size by the searches (worth it for many searches; a few scan as fast).
SearchReach make_search_reach(const Mesh& mesh, bool with_grid = true);

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

//! True if \p faces form a disk, their boundary edges one closed loop through distinct vertices,
//! whose loop projects onto the plane through the faces' area-weighted normal as a simple
//! polygon and whose faces all project there with the same strict orientation
//! (projects_injectively): then no two of them intersect. For a region of a patch split along
//! crease curves, which as a whole folds over every plane.
bool disk_projects_injectively(const Mesh& mesh, std::span<const FaceHandle> faces);

//! Like find_face_intersections, but two faces of \p faces in the same group are not tested
//! against each other when that group is known not to intersect itself: \p group[i] is face
//! i's group, and \p embedded[g] says whether group g is (disk_projects_injectively).
std::vector<std::pair<FaceHandle, FaceHandle>> find_intersections_between_groups(
    const Mesh& mesh, std::span<const FaceHandle> faces, std::span<const int> group,
    std::span<const char> embedded, std::size_t stop_after, const SearchReach& reach);

//! Every intersecting pair of faces of the whole mesh.
std::vector<std::pair<FaceHandle, FaceHandle>> find_self_intersections(const Mesh& mesh,
                                                                       std::size_t stop_after = 0);

}  // namespace touchmend::geometry
