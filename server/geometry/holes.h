#pragma once

//! \file holes.h
//! \brief Hole search (seed 000 §3.3) and hole properties (seed 000 §3.4.1, seed 001 §2.1).

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "server/geometry/mesh.h"

namespace touchmend::geometry {

//! One boundary loop. Its vertices run along the boundary halfedges (OpenMesh's
//! boundary halfedges, face = null), so the hole lies on the left and the loop turns
//! counter-clockwise around the hole seen from outside the surface.
struct Hole {
  //! Stable id: the smallest vertex index on the loop (ties between holes that share that
  //! vertex go to the next-smallest free index). Unchanged by edits elsewhere in the mesh,
  //! and by writing and re-reading the mesh, since vertex indices are kept.
  std::uint32_t id = 0;
  std::vector<VertexHandle> loop;
  std::vector<HalfedgeHandle> halfedges;  //!< halfedges[i] runs loop[i] -> loop[i+1]
  double perimeter = 0;
  double mean_edge_length = 0;
  double area = 0;       //!< |Newell vector area| (exact for planar loops, a lower bound otherwise)
  Vec3 normal{0, 0, 0};  //!< mean unit normal of the boundary triangles (seed 000 §3.4.1)
  Vec3 newell_normal{0, 0, 0};
  Vec3 centroid{0, 0, 0};  //!< arc-length-weighted centroid of the boundary polyline
  double planarity = 0;    //!< max distance of the boundary to its least-squares plane
  //! True when the boundary projects onto a reference plane without self-intersection or
  //! fold-over (a "simple" hole, seed 001 §2.1); false for a "complex" hole.
  bool is_simple = false;
  Vec3 reference_normal{0, 0, 1};  //!< the plane normal that made it simple (if simple)
  std::string reference_source;    //!< "boundary-triangles", "newell", "pca" or "none"
  //! Whether is_simple/reference_* were computed (find_holes can skip the O(n^2) test).
  bool projectability_computed = false;
  //! Empty when the hole can be filled; otherwise why not (e.g. a non-manifold vertex).
  std::string unfillable_reason;
  //! Vertices the loop passes more than once (a hole pinched at a vertex: the region left
  //! between an island of faces and the rest of the surface that it touches at one vertex, the
  //! outside of a bowtie), each listed once, by index. The fill closes each pinch with one
  //! triangle first (see fill_hole).
  std::vector<VertexHandle> pinched_at;
  //! When the loop is the whole border of a small separate piece (count_fragment_faces): its
  //! face count; 0 otherwise. Set with the other properties (compute_hole_properties).
  std::size_t fragment_faces = 0;

  std::size_t size() const { return loop.size(); }
};

struct HoleSearchResult {
  std::vector<Hole> holes;
  std::size_t corrupt_fans = 0;  //!< walks around a vertex that did not terminate (reported)
};

struct HoleSearchOptions {
  bool compute_projectability = true;  //!< the O(n^2) simplicity test; off for a quick count
};

//! Finds every boundary loop. A vertex shared by two holes (seed 000 Fig. 3.5, which the
//! thesis leaves out) is resolved from the fans around it, never from the kernel's arbitrary
//! boundary links: see next_hole_halfedge.
HoleSearchResult find_holes(const Mesh& mesh, const HoleSearchOptions& options = {});

//! The holes after an edit, without a search of the whole mesh: \p result holds the holes
//! before it (find_holes or this), \p touched every vertex that is a corner of a face the edit
//! added or deleted, that it moved, or that neighbours a moved one (whose faces' normals
//! changed). A loop through none of them is kept with its properties (its fragment count made
//! again); the loops through them are traced again. The result is find_holes' (the same loops,
//! order and ids; the kept holes' projectability as it was computed). False when a fan is
//! corrupt, or was at the search \p result came from: \p result is then unchanged and only a
//! search of the whole mesh answers. The interactive session's path: a fill request on a mesh
//! of a million faces spent 9-11 ms in the search alone.
bool update_holes(const Mesh& mesh, HoleSearchResult& result, std::span<const VertexHandle> touched,
                  const HoleSearchOptions& options = {});

//! The outgoing boundary halfedge that follows the boundary halfedge \p incoming along its
//! hole: at a manifold vertex the far end of the one fan; where holes touch, the end of
//! another fan bounding the same gap (ALGORITHMS.md §1.2's same-fan rule alone would join the
//! two holes into a figure 8). Invalid if the fan is corrupt.
HalfedgeHandle next_hole_halfedge(const Mesh& mesh, HalfedgeHandle incoming);

//! The loop the boundary links from boundary halfedge \p start (next_hole_halfedge at each
//! vertex) into \p hole's loop and halfedges (its other fields untouched): false when it does
//! not come back to \p start within \p max_edges edges or a fan is corrupt. For a loop an edit
//! has just made (a triangle across a pinch, two joining a ring's borders).
bool trace_hole_loop(const Mesh& mesh, HalfedgeHandle start, std::size_t max_edges, Hole& hole);

//! Index of the hole with \p id in \p holes, if any.
std::optional<std::size_t> find_hole_by_id(const std::vector<Hole>& holes, std::uint32_t id);

//! The hole whose boundary polyline passes closest to \p point (what the haptic station's
//! selection calls), with that distance.
struct NearestHole {
  std::size_t index;
  double distance;
};
std::optional<NearestHole> find_nearest_hole(const Mesh& mesh, const std::vector<Hole>& holes,
                                             const Vec3& point);

//! The face count of the piece of surface \p hole borders when that piece is a small fragment:
//! connected to nothing else, bordered by this loop alone, and of no more faces than the loop
//! has edges (a lone triangle a cut left, a few faces of a scan's debris); 0 otherwise. A patch
//! of such a loop is a second skin on the piece's back, which the intersection test refuses
//! when the piece is flat. Measured on random cuts of overlapping balls into the shared meshes:
//! 6 of the 19 holes left open (seeds 1-3) are such outlines, of one to four faces.
std::size_t count_fragment_faces(const Mesh& mesh, const Hole& hole);

//! The faces of that fragment (count_fragment_faces), in index order; empty when the piece
//! \p hole borders is not one.
std::vector<FaceHandle> fragment_piece(const Mesh& mesh, const Hole& hole);

//! Recomputes the geometric properties of \p hole from its loop (used after edits).
void compute_hole_properties(const Mesh& mesh, Hole& hole, bool compute_projectability);

}  // namespace touchmend::geometry
