#pragma once

//! \file gap_bridging.h
//! \brief Gap bridging between two registered surfaces (seed 000 §4.3): one stitch triangle
//! from a boundary edge to a boundary vertex (Algorithm VIII, §4.3.1), and closing a gap by a
//! stitch at each end followed by the hole filler (Algorithm IX, §4.3.2).
//!
//! \details The thesis leaves the stitch unvalidated and unoriented; the rules here follow
//! ALGORITHMS.md §4.1: the edge must be a boundary edge and the vertex a boundary vertex; the
//! new face takes the free direction of the edge (so it is oriented like the face it joins);
//! its other two edges must be new or boundary edges used in their free direction (else the
//! result would be non-manifold); a face whose normal opposes both neighbourhoods means the
//! surfaces have opposite orientations; a degenerate face or one that intersects the mesh is
//! refused. A refused stitch leaves the mesh unchanged.
//! (The server and station wiring, the CLI and automatic gap detection are still to come.)

#include <string>
#include <vector>

#include "server/geometry/hole_filling.h"
#include "server/geometry/mesh.h"

namespace touchmend::geometry {

struct StitchOptions {
  bool check_intersections = true;
};

struct StitchResult {
  bool ok = false;
  std::string reason;  //!< why it was refused
  FaceHandle face;
};

//! One stitch triangle over the boundary edge {a, b} to the boundary vertex \p t.
StitchResult stitch_triangle(Mesh& mesh, VertexHandle a, VertexHandle b, VertexHandle t,
                             const StitchOptions& options = {});

struct GapEnd {
  VertexHandle a, b;  //!< a boundary edge of one surface
  VertexHandle t;     //!< a boundary vertex of the other surface
};

struct GapBridgeResult {
  bool ok = false;
  std::string reason;
  std::vector<FaceHandle> stitches;   //!< the two end triangles
  std::vector<HoleFillReport> fills;  //!< the loops they closed, filled
};

//! Algorithm IX: stitches both ends, then fills the loop that now runs through both stitches
//! (the shorter one: the other is the outer boundary). If a stitch is refused nothing is
//! added (a first stitch is deleted again; collect garbage before export); if the fill fails
//! the stitches stay and the reason says so.
GapBridgeResult bridge_gap(Mesh& mesh, const GapEnd& first, const GapEnd& second,
                           const FillOptions& fill = {}, const StitchOptions& stitch = {});

}  // namespace touchmend::geometry
