#pragma once

//! \file ring_joining.h
//! \brief [ours] Two boundary loops that border one ring-shaped hole (an annulus), joined into
//! one loop the filler closes.
//!
//! \details A cut that takes a ring of faces (the floor of a counterbore around its bore, the
//! flat face around a boss, a band around an island) leaves two loops, one inside the other on
//! one plane, running opposite ways. Each filled alone is wrong: the outer loop's patch spans
//! the inner loop's surface (it crosses the bore's wall and is refused, or lies on the island),
//! and the inner loop's patch caps what it borders (it closes the bore). The seed fills holes
//! one loop at a time (seed 000 §3.3 finds each loop); Algorithm IX (§4.3) shows the way for
//! two borders: triangles between them first, then the filler on the loop left. Here two
//! triangles across the narrowest place of the ring join its borders into one loop, which then
//! goes the planar way as any other.
//!
//! The ring may also lie on two levels: a slot along a pocket's or a counterbore's rim takes the
//! wall below the rim with it, and the loops left are the mouth's border and the floor's, on two
//! parallel planes. Filled alone, the mouth is capped at the top and the floor's border (its
//! missing surface lies outside it) cannot be filled at all; joined, the loop left is the wall,
//! which the 3D triangulation spans. Where a few of the wall's triangles stand (teeth), the
//! mouth's border dips down them and back.

#include <span>
#include <string>
#include <utility>
#include <vector>

#include "server/geometry/holes.h"
#include "server/geometry/mesh.h"
#include "server/geometry/mesh_intersections.h"

namespace touchmend::geometry {

struct RingBorderOptions {
  //! Both loops lie within this fraction of the outer loop's radius (sqrt(area / π)) of the
  //! outer loop's plane.
  double max_off_plane = 0.1;
  //! The inner loop may instead lie on a plane parallel to the outer one's, at most this many
  //! outer radii off it (two levels: the cut took the wall between them too).
  double max_level_offset = 2.0;
};

//! Whether \p inner is the inner border of a ring whose outer border is \p outer: the outer loop
//! is near-planar, every vertex of the inner one lies near its plane (or near one parallel plane
//! within RingBorderOptions::max_level_offset) and inside its outline (projected on that plane;
//! on a second level also on the outline, where a straight wall puts it; the outer loop may then
//! dip towards the inner level at up to a quarter of its vertices), and the two run
//! opposite ways (their Newell normals point apart, as the two borders of one region do). Neither
//! may be pinched or unfillable.
bool borders_one_ring(const Mesh& mesh, const Hole& outer, const Hole& inner,
                      const RingBorderOptions& options = {});

//! Pairs (outer, inner) of \p holes (indices into it) that border one ring each; a hole is in
//! one pair at most (an outer loop with several loops inside pairs with none: it is not one
//! ring).
std::vector<std::pair<std::size_t, std::size_t>> find_ring_borders(
    const Mesh& mesh, std::span<const Hole* const> holes, const RingBorderOptions& options = {});

struct RingJoin {
  std::vector<FaceHandle> faces;  //!< the two joining triangles
  Hole hole;                      //!< the one loop left (with the outer loop's id)
  std::string failure;            //!< empty on success; the mesh is then as it was
};

//! Joins the borders of a ring with two triangles (a, b, t) and (t, t', a) across its narrowest
//! place: a -> b a boundary edge of \p outer, t -> t' one of \p inner, the quad a, b, t, t'
//! chosen with the shortest sides b-t and t'-a whose triangles face the way a patch of the outer
//! loop would (on two levels: not against it, they stand on its plane as a piece of the wall)
//! and meet no other face. The loop left runs ... a, t', (the inner loop) ..., t, b,
//! (the outer loop) ...: as many edges as the two loops had.
RingJoin join_ring_borders(Mesh& mesh, const Hole& outer, const Hole& inner,
                           const SearchReach& reach);

}  // namespace touchmend::geometry
