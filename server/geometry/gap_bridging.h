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
//!
//! Beyond the thesis, for automated clients: find_gaps() detects runs of boundary vertices that
//! face runs of another boundary (or of a distant part of the same one) across the empty space,
//! within a width, and zip_gap() closes such a gap with a zipper triangulation (advancing along
//! both runs, always taking the shorter new diagonal), each triangle validated like a stitch.

#include <cstdint>
#include <string>
#include <vector>

#include "server/geometry/hole_filling.h"
#include "server/geometry/mesh.h"
#include "server/geometry/mesh_intersections.h"

namespace touchmend::geometry {

struct StitchOptions {
  bool check_intersections = true;
  //! Where the intersection searches look, kept across the stitches of a zipper (each stitch
  //! is filed in it); null: measured for the one stitch, O(mesh size).
  SearchReach* reach = nullptr;
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

//! Two boundary runs facing each other across the empty space.
struct Gap {
  std::uint32_t id = 0;                  //!< index in find_gaps' result (stable for one mesh state)
  std::uint32_t hole_a = 0, hole_b = 0;  //!< ids of the boundary loops (equal: one loop)
  //! run_a follows its loop's direction; run_b follows its own, so run_a.front() faces
  //! run_b.back(). A run that is its whole loop is closed (cyclic).
  std::vector<VertexHandle> run_a, run_b;
  bool cyclic = false;  //!< both runs are whole loops (a band cut around a closed surface)
  double mean_width = 0, max_width = 0;
  double length = 0;  //!< along run_a
};

struct GapOptions {
  //! Boundary vertices farther apart than this are not a gap; 0 = 3 x the mean boundary edge.
  double max_width = 0;
  //! Directions across the gap must agree within this angle with both sides' outward
  //! (away from their faces, in the tangent plane) directions.
  double facing_angle_deg = 60;
  std::size_t min_run_edges = 2;  //!< shorter runs are not reported
};

std::vector<Gap> find_gaps(const Mesh& mesh, const std::vector<Hole>& holes,
                           const GapOptions& options = {});

struct ZipResult {
  bool ok = false;
  std::string reason;
  std::vector<FaceHandle> faces;
};

//! Closes \p gap with a zipper triangulation. Each triangle is checked like a stitch (no
//! flipped, non-manifold or intersecting face); on the first refusal the faces added so far are
//! deleted again and the reason says where it stopped.
ZipResult zip_gap(Mesh& mesh, const Gap& gap, const StitchOptions& options = {});

struct DetectedGapBridge {
  ZipResult zip;
  std::vector<HoleFillReport> end_fills;  //!< the small holes left at the ends, filled
};

//! An automatic bridge: the zipper, then the small holes it leaves at the two ends of a
//! non-cyclic gap (loops through the zipper's faces no longer than 4 gap widths plus the
//! runs' end edges) closed by the hole filler.
DetectedGapBridge bridge_detected_gap(Mesh& mesh, const Gap& gap, const FillOptions& fill = {},
                                      const StitchOptions& options = {});

struct DetectedGapsBridge {
  std::vector<DetectedGapBridge> gaps;  //!< one per gap asked for, in order
  //! The narrow holes the zippers left (pieces of a band between two gaps' runs, or where a
  //! run ended), closed by the hole filler.
  std::vector<HoleFillReport> leftover_fills;
  std::size_t bridged() const;
};

//! Several detected gaps (all of a band, say): each zipped as bridge_detected_gap does, then
//! every hole next to the zippers' faces that is a narrow strip (area / perimeter at most the
//! widest bridged gap's width — a strip of width w has w / 2) is filled: a band cut through an
//! irregular surface breaks into several facing runs, and what lies between them is closed
//! here instead of being left open.
DetectedGapsBridge bridge_detected_gaps(Mesh& mesh, const std::vector<const Gap*>& gaps,
                                        const FillOptions& fill = {},
                                        const StitchOptions& options = {});

}  // namespace touchmend::geometry
