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

//! After the disk is filled, the edge p-a of each pinch-closing triangle (p, v, a), now shared
//! with a patch triangle (p, a, x), is flipped to v-x when that makes the pair's smaller angle
//! larger, neither new triangle turns more than 60° from the pair it replaces, and neither meets
//! another face: the closing triangle was chosen before the patch existed, and this edge is
//! the one part of it the patch's own mending, which keeps the rim fixed, cannot move. Returns
//! the number of flips.
std::size_t flip_pinch_closing_edges(Mesh& mesh, const PinchClosure& closure,
                                     const SearchReach& reach);

}  // namespace touchmend::geometry
