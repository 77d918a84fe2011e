#pragma once

//! \file patch_quality.h
//! \brief Triangle quality of a fill patch (DESIGN: "minimum angle ≥ 15° for refined fills").
//!
//! \details Liepa's refinement (Algorithm III) places vertices at centroids and relaxes by the
//! circumsphere test, which keeps the slivers of the initial triangulation where they touch the
//! boundary, and a flat patch may only flip edges between coplanar triangles. This pass works on
//! the triangles whose smallest angle is below a goal, with the patch's boundary fixed:
//!  - min-angle edge flips: an interior edge is flipped when the smaller angle of its two
//!    triangles grows (in the plane this is the Delaunay flip: it maximises the minimum angle);
//!  - tangential smoothing: a free vertex moves towards the centre of its ring, in its tangent
//!    plane, and only when the smallest angle around it grows (so the pass never makes the worst
//!    triangle worse);
//!  - longest-edge bisection (Rivara) of the triangles still bad, when that edge is interior:
//!    the midpoint of a fold between two planes lies on both, so even a flat patch keeps its
//!    surface exactly;
//!  - optionally, for caps (an obtuse angle, which bisection would only halve), insertion of
//!    the circumcentre with Lawson flips around it, Ruppert's Delaunay refinement step (J.
//!    Ruppert, "A Delaunay refinement algorithm for quality 2-dimensional mesh generation",
//!    1995): the rim cannot be split, so a circumcentre past it or encroaching on it is not
//!    inserted, and a fold of a flat patch is split at its midpoint instead;
//!  - optionally, collapse of a free vertex of a triangle still bad into another corner of it,
//!    when that raises the smallest angle around it (a vertex fairing pulled against a fixed
//!    edge: every position in its tangent plane leaves an obtuse cap, and flips are limited).
//! Nothing outside the patch changes; vertices on the patch's boundary never move. What all of
//! these leave under the goal beside a short edge nothing may change (a rim edge, a link between
//! crease corners) gets, last, a graded refinement by off-centres (refine_graded below), kept
//! only where it raises the smallest angle.

#include <cstddef>
#include <span>
#include <vector>

#include "server/geometry/mesh.h"

namespace touchmend::geometry {

struct PatchQualityOptions {
  //! Triangles with a smaller angle are worked on (a margin over the 15° goal, since fairing
  //! afterwards distorts the shapes a little).
  double target_min_angle_deg = 20.0;
  int max_rounds = 8;
  //! The patch is final as it is (flat): flips and moves only where the triangles involved fold
  //! by less than `flat_fold_deg`, and turn no triangle by more, so a planar region stays
  //! exactly in its plane and a crease between planes (far sharper) is never touched; only the
  //! soft folds of a spanning triangulation over a non-planar boundary may change a little.
  bool keep_surface = false;
  //! 15°: a crease-split region spanning a slightly non-planar boundary folds by 12° on
  //! fandisk_sharp #1, and with 10° a 153° cap across that fold stayed (worst angle 11.3°, 18.0°
  //! with 15°; no other hole of the benches changes but for ±0.01‰); the weakest crease a plan
  //! splits along bends by 30° (CreaseOptions::partner_angle_deg).
  double flat_fold_deg = 15.0;
  //! keep_surface: a flip may move the surface by at most this fraction of the quad's longer
  //! diagonal (the distance between the two diagonals bounds the move).
  double flat_flip_tolerance = 0.01;
  //! Otherwise (the patch will be faired): a flip or move may turn a triangle's normal by at
  //! most this, so the spanning surface is not folded.
  double max_turn_deg = 30.0;
  //! Bisection is for needles; a cap (one angle above this) is mended by flipping its long
  //! edge instead, since bisecting it puts the new vertex next to the obtuse one.
  double max_bisected_angle_deg = 120.0;
  bool bisect = true;  //!< false: no bisections
  //! Caps (an angle over max_bisected_angle_deg) that flips and moves leave below the goal:
  //! insert their circumcentres and flip around them (Ruppert's Delaunay refinement step;
  //! each insertion is undone unless it mends the cap). Off by default; the fill asks for it on
  //! flat patches. Not before fairing (fairing moves the point again: measured, rocker-arm_xl's
  //! faired patch then crossed the mesh), nor on a faired surface (the point would lie on a chord,
  //! off it).
  bool insert_circumcentres = false;
  //! Collapse a free vertex of a triangle that flips and moves left below the goal into
  //! another corner of it (removes a vertex fairing pulled next to a fixed edge). Coarsens the
  //! patch, so off unless asked for (the fill asks for it on the final faired surface).
  bool collapse = false;
  //! Also try moving a vertex towards the apex that makes its worst triangle equilateral
  //! (mends a vertex pulled next to a fixed edge; larger moves than Laplacian smoothing).
  bool apex_moves = false;
  //! Edges shorter than this fraction of the median edge on the patch's boundary are not
  //! bisected (the patch's density was set by the refinement; this only mends shapes).
  double min_split_length = 0.5;
};

struct PatchQualityReport {
  int rounds = 0;
  std::size_t flips = 0;
  std::size_t moves = 0;
  std::size_t splits = 0;
  std::size_t collapses = 0;
  double min_angle_before_deg = 180;
  double min_angle_after_deg = 180;
};

//! Improves the triangles of \p patch_faces in place. Faces and vertices the bisections create
//! are appended to \p patch_faces and \p new_vertices; those collapses delete are removed from
//! both (the mesh keeps them as deleted elements until its garbage collection). A vertex is free
//! (may move) when every face around it is in the patch and, with keep_surface, they are coplanar.
PatchQualityReport improve_patch_quality(Mesh& mesh, std::vector<FaceHandle>& patch_faces,
                                         std::vector<VertexHandle>& new_vertices,
                                         const PatchQualityOptions& options = {});

//! A triangle of the patch with two sides on its rim and a nearly straight corner between them:
//! a split along a crease curve leaves one where the curve's chord cuts off a single rim vertex
//! (the crease runs along the rim there, so one side of the chord is only that sliver), and
//! the per-region passes above cannot flip the chord, which borders two regions. Its one
//! interior edge is flipped, so the two new triangles take the rim vertex and the crease
//! follows the rim, when:
//!  - the smaller angle of the two triangles grows and was below \p goal_deg;
//!  - the rim vertex lies within \p max_width of the chord's length from the chord (the flip
//!    moves the surface by at most that);
//!  - neither new triangle turns further than \p max_turn_deg from the pair's area-weighted
//!    normal (the sliver's own normal is noise).
struct RimSliverOptions {
  double goal_deg = 15.0;
  double max_width = 0.1;
  double max_turn_deg = 30.0;
};

//! Flips the chords of the rim slivers of \p patch_faces (see RimSliverOptions); returns the
//! number of flips. Face handles stay valid (a flip reuses both faces). \p face_regions, if not
//! empty, is each face's region (aligned with \p patch_faces): both flipped faces then belong to
//! the region across the chord, which the rim vertex joins (the sliver's region loses its only
//! triangle there), so no edge of the pair is taken for a segment of a curve afterwards.
std::size_t flip_rim_slivers(Mesh& mesh, const std::vector<FaceHandle>& patch_faces,
                             std::span<int> face_regions = {},
                             const RimSliverOptions& options = {});

//! Graded refinement of a whole patch, for the triangles the passes above leave below a goal
//! (patch_quality.cpp: Patch::refine_graded). A patch split along crease curves is given with
//! its faces' regions: an edge between two regions is a segment of a curve, never flipped, and
//! split at its midpoint (which lies on both regions' surfaces) where a new vertex would
//! encroach on it, as Ruppert's refinement splits a segment; the rim (the mesh's) is never
//! split, and a new vertex that would encroach on it moves off it. Where a triangle has a
//! corner of the rim between two edges of very unequal length, a graded fan of triangles at
//! that corner is tried too (the corner's free neighbours moved onto it).
struct GradedRefinementOptions {
  //! Triangles below this angle are worked on (DESIGN's goal for refined fills).
  double below_deg = 15.0;
  //! The off-centres make triangles with this angle at the new vertex (the coarsest grading the
  //! goal allows).
  double goal_deg = 25.0;
  //! At most this many new vertices per triangle below the goal.
  int max_insertions = 6;
  //! A flip may turn a triangle's normal by at most this (as the fill's last quality pass).
  double max_turn_deg = 60.0;
  //! The patch is final as it is (flat, PatchQualityOptions::keep_surface): new vertices lie on
  //! its triangles, flips and moves keep its surface, a walk across a fold splits the fold at
  //! its midpoint, and a corner fan is tried only where the corner's triangles are coplanar.
  bool keep_surface = false;
};

struct GradedRefinementReport {
  std::size_t inserted = 0;  //!< vertices kept
  std::size_t undone = 0;    //!< refinements undone (they did not raise the smallest angle)
  //! Triangles not worked on: their smallest angle is a corner of their region between two
  //! rim edges or segments, which no new vertex can widen.
  std::size_t fixed_corners = 0;
  double min_angle_before_deg = 180;
  double min_angle_after_deg = 180;
};

//! Refines the triangles of \p patch_faces below options.below_deg in place, keeping each
//! refinement only where it raises the smallest angle of the triangles it touched. New faces
//! and vertices are appended to \p patch_faces (with their regions in \p face_regions, aligned
//! with the faces; empty: one region) and \p new_vertices; the faces an undone refinement
//! deleted leave both lists. Regions not aligned with the faces: nothing is done.
GradedRefinementReport refine_graded(Mesh& mesh, std::vector<FaceHandle>& patch_faces,
                                     std::vector<int>& face_regions,
                                     std::vector<VertexHandle>& new_vertices,
                                     const GradedRefinementOptions& options = {});

//! How many triangles of \p faces have an angle under \p degrees.
std::size_t count_faces_below(const Mesh& mesh, const std::vector<FaceHandle>& faces,
                              double degrees);

//! Smallest angle (degrees) of the triangles of \p faces.
double min_angle_deg(const Mesh& mesh, const std::vector<FaceHandle>& faces);

//! A new triangle with a smaller angle (degrees) is (numerically) degenerate: its normal is
//! noise. The fill and the sharp-edge tools refuse to leave one where they have a choice.
constexpr double kDegenerateAngleDeg = 0.1;

}  // namespace touchmend::geometry
