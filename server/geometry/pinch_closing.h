#pragma once

//! \file pinch_closing.h
//! \brief Making a pinched hole (a loop through a vertex more than once) a disk the filler can
//! close, and touching up the triangles that did it once the disk is filled.

#include <array>
#include <string>
#include <vector>

#include "server/geometry/holes.h"
#include "server/geometry/mesh.h"
#include "server/geometry/mesh_intersections.h"

namespace touchmend::geometry {

//! The triangles that closed a pinched hole's pinches, and the hole left (a disk), or why not.
struct PinchClosure {
  std::vector<FaceHandle> faces;
  std::vector<std::array<VertexHandle, 3>> corners;  //!< (p, v, a) of each face
  Hole hole;
  std::string failure;  //!< empty on success
};

//! Closes each pinch of \p hole (a vertex its loop passes more than once) with one triangle.
//!
//! [ours] A loop through vertex v twice, ... p -> v -> a ... b -> v -> q ..., bounds a region
//! that is a disk with two boundary points glued at v: the gap left between an island of faces
//! and the surface it touches at v (a scan's debris, two cuts that met), a pinched annulus. Its
//! two corners at v are the two gaps between v's fans. One triangle across either corner,
//! (p, v, a) with the new edge p-a, joins the two fans at v into one: the loop then passes v
//! once and is one vertex shorter, a disk the filler closes like any other (the same idea as
//! seed 000 §4.3's Algorithm IX, which closes a gap's ends with one triangle each and fills
//! the hole left). Of the corners at v the triangle with the largest smallest angle is taken
//! that creates no edge the mesh already has, is not degenerate, links into the mesh and
//! meets no other face; first among those that continue the surface (fold by at most 60°
//! against both rim faces they join), then the others. The pinch is then no longer in the loop,
//! whatever the fill does: on failure the caller removes the triangles, so the mesh is as it was.
PinchClosure close_pinches(Mesh& mesh, const Hole& hole, const SearchReach& reach);

//! [ours] Closes the rim's narrow notches with their ears before the fill: a corner p -> v -> a
//! narrower than 15° (DESIGN's smallest angle: a triangulation that stays on the surface there
//! has a triangle at v no wider than the corner, and the ear is the widest one when the corner
//! is its smallest angle) whose
//! ear (p, v, a) continues both rim faces within 30°, creates no edge the mesh has, and meets no
//! other face. Found by random cuts into couplingdown, whose cylinder walls are strips of long
//! triangles: a cut that takes every other one leaves a comb whose every gap is such a notch,
//! exactly the triangle cut away; filled as part of the hole, the gaps' slivers were split and
//! faired off the wall (60-83 per mille of the diagonal off the removed faces). The seed's
//! closing of boundary angles (seed 000 §3.4.2, for the planar method, under 5π/9) keeps the
//! notches' neighbours too; this is its 3D counterpart for the narrowest corners, whose ears lie
//! on the surface when their two rim faces do. A spike of the surface into the hole (its tip is a
//! narrow corner too) is not a notch: its ear lies on the spike's back and folds by 180°. No ear
//! closed: \p hole itself, no faces. The faces carry no corners (nothing to flip afterwards).
PinchClosure close_notches(Mesh& mesh, const Hole& hole, const SearchReach& reach);

//! Whether the rim's corner at loop position \p i of \p hole looks like a notch close_notches
//! closes: narrower than 15°, its ear continuing both rim faces within 30° (the geometry alone:
//! whether the ear meets the mesh is not tried).
bool is_narrow_notch(const Mesh& mesh, const Hole& hole, std::size_t i);

//! After the disk is filled, the edge p-a of each pinch-closing triangle (p, v, a), now shared
//! with a patch triangle (p, a, x), is flipped to v-x when that makes the pair's smaller angle
//! larger, neither new triangle turns more than 60° from the pair it replaces, and neither meets
//! another face: the closing triangle was chosen before the patch existed, and this edge is
//! the one part of it the patch's own mending, which keeps the rim fixed, cannot move. Returns
//! the number of flips.
std::size_t flip_pinch_closing_edges(Mesh& mesh, const PinchClosure& closure,
                                     const SearchReach& reach);

}  // namespace touchmend::geometry
