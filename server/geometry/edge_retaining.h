#pragma once

//! \file edge_retaining.h
//! \brief Sharp-edge retaining on a filled hole (seed 000 §4.2, Algorithms V-VII, with the
//! precise versions of ALGORITHMS.md §3.2-3.4): a guiding surface ("curtain") through the
//! Hermite curve, vertex snapping onto it (Algorithm V), push-down of curtain vertices toward the
//! curve by tool sweeps (Algorithm VI) and smoothing by normal propagation (Algorithm VII).
//!
//! \details The curtain is {Q(t) + s·n}: the Hermite curve extruded along the hole normal n.
//! Seen along n it is the polyline of the sampled curve, so every edge/curtain crossing is a 2D
//! segment/polyline crossing in the hole's projection, and every curtain vertex carries its
//! curtain coordinates (t, s): s = 0 is the curve. Pushing a vertex "down" moves it along n
//! inside the curtain toward s = 0, which is where its motion line meets the curve (a generic
//! line would miss a space curve); the sign of s makes concave and convex edges one case (the
//! thesis handles concave only, §4.2). The thesis' option to go past the curve (§6.2) is
//! `PushOptions::depth`.

#include <map>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "server/geometry/hermite_curve.h"
#include "server/geometry/mesh.h"
#include "server/geometry/projection.h"

namespace touchmend::geometry {

//! The guiding surface: the sampled curve extruded by ±height along the unit normal.
struct GuideSurface {
  HermiteCurve curve;
  std::vector<CurveSample> samples;  //!< the curve at ~ boundary edge length (seed 000 §4.2.1)
  Vec3 normal{0, 0, 1};              //!< extrusion direction (unit)
  double height = 0;                 //!< half-height of the extrusion
  ReferenceFrame frame;              //!< projection along `normal`
  std::vector<Point2> polyline;      //!< the samples seen along `normal`

  //! The curtain as triangles (two per curve segment), for display and intersection tests.
  std::vector<std::array<Vec3, 3>> triangles() const;
};

//! \p segment_length: the boundary edge length around the hole; \p height: how far the
//! curtain reaches to either side (ALGORITHMS.md §3.2: enough to cut every patch triangle).
GuideSurface make_guide_surface(const HermiteCurve& curve, const Vec3& normal,
                                double segment_length, double height);

//! A vertex on the curtain: Q(t) + s·n.
struct CurtainPoint {
  double t = 0;
  double s = 0;
  int side = 0;  //!< sign of s when the vertex joined the curtain (which way "down" is)
};

//! Where a point seen along the normal crosses the curve's polyline; the parameter t of the
//! crossing and the height s of the point above the curve there.
std::optional<CurtainPoint> curtain_coordinates(const GuideSurface& guide, const Vec3& p,
                                                double tolerance);

//! State of one sharp-edge edit on a filled hole.
struct SharpEdgeState {
  GuideSurface guide;
  std::vector<FaceHandle> patch;         //!< the filled hole's faces (grows with splits)
  std::set<int> boundary;                //!< the hole's boundary vertices: never move
  std::map<int, CurtainPoint> on_guide;  //!< curtain vertices (Algorithm V)
  std::set<int> moved;                   //!< vertices a push has moved (fixed for VII)
};

enum class SnapMode {
  Move,   //!< the thesis: move the nearer non-boundary end to the crossing
  Split,  //!< split every crossing edge at the crossing (a new vertex on the curtain)
  Auto,   //!< move unless that would fold a triangle over, then split
};

struct SnapOptions {
  SnapMode mode = SnapMode::Auto;
};

struct SnapReport {
  std::size_t crossings = 0;  //!< patch edges crossing the curtain
  std::size_t moved = 0;      //!< vertices moved onto it
  std::size_t splits = 0;     //!< edges split at the crossing
  std::size_t flips = 0;      //!< edges flipped so curtain vertices form a chain
  std::vector<VertexHandle> new_vertices;
};

//! Algorithm V: puts the patch's vertices onto the curtain where its edges cross it, then
//! flips edges so consecutive curtain vertices are joined (a crease can form along them).
SnapReport snap_to_guide(Mesh& mesh, SharpEdgeState& state, const SnapOptions& options = {});

struct PushOptions {
  double step = 0;   //!< distance per tool sample (the thesis' user-set step)
  double depth = 0;  //!< how far past the curve a vertex may go (0: stop at the curve)
};

struct PushResult {
  bool moved = false;
  std::string why_not;
  VertexHandle vertex;
  Vec3 from{0, 0, 0}, to{0, 0, 0};
  bool at_limit = false;  //!< reached the curve (or the depth past it)
};

//! Algorithm VI, one tool sample: of the touched face's curtain vertices, the one nearest the
//! line of motion through the proxy moves one step along the curtain toward (and with a depth,
//! past) the curve. Needs a motion (|proxy - previous| > 0).
PushResult push_down(Mesh& mesh, SharpEdgeState& state, const Vec3& proxy,
                     const Vec3& previous_proxy, FaceHandle touched, const PushOptions& options);

//! Every curtain vertex straight to its limit (the end state of enough sweeps; for automated
//! clients). Returns the number moved.
std::size_t push_all(Mesh& mesh, SharpEdgeState& state, const PushOptions& options);

struct SmoothReport {
  std::size_t moved = 0;
  std::size_t rounds = 0;
};

//! Algorithm VII: marching from the fixed vertices (boundary, curtain, pushed) over visited
//! edges, each free vertex is rotated about the visited edge of its triangle until that
//! triangle's normal is the mean of the edge ends' normals (averaged over its triangles), then
//! fixed; until every vertex is fixed.
SmoothReport smooth_by_normal_propagation(Mesh& mesh, const SharpEdgeState& state);

//! Which side of the guide's curve \p p lies on, seen along the guide's normal: +1 left of the
//! polyline (in the direction P2 -> P3), -1 right, by its nearest segment.
int side_of_curve(const GuideSurface& guide, const Vec3& p);

struct CurveFairingReport {
  bool ok = false;
  std::string failure;
  std::size_t moved = 0;  //!< free vertices faired (both sides)
};

//! The finish ALGORITHMS.md §3.4 recommends after a push-down instead of Algorithm VII: the
//! patch's free vertices (not on the boundary, the curtain or pushed) are faired by the
//! bi-Laplacian (fairing.h) with everything else fixed, each side of the curve on its own (the
//! other side's patch faces are left out of its operator), so each side meets the surroundings
//! with matching tangents and the crease along the curtain vertices stays sharp. Algorithm VII
//! marches normals in from the boundary in one pass and accumulates error toward the middle
//! (measured on the *_sharp cases: README "Sharp edges"). On failure nothing moves.
CurveFairingReport fair_beside_curve(Mesh& mesh, const SharpEdgeState& state);

//! What shapes the rest of the patch after a push-down.
enum class PushFinish {
  Fair,    //!< fair_beside_curve (ALGORITHMS.md §3.4's recommendation)
  Smooth,  //!< smooth_by_normal_propagation, the thesis' Algorithm VII
  None,    //!< leave the first fill's shape
};
const char* to_string(PushFinish finish);
bool parse_push_finish(std::string_view text, PushFinish& finish);

struct PushFinishReport {
  SmoothReport smooth;         //!< PushFinish::Smooth
  CurveFairingReport fairing;  //!< PushFinish::Fair
  //! Why the finish was undone (the fairing failed, or the patch would intersect the mesh);
  //! nothing then moved. Empty: the finish was kept.
  std::string undone;
};

//! The finish after the pushes (the batch `sharpen` and the station's last step): shapes the
//! free vertices by \p finish and undoes it when it fails or, with \p check_intersections,
//! when the patch would then intersect the mesh; the pushed crease stays either way.
PushFinishReport finish_push(Mesh& mesh, const SharpEdgeState& state, PushFinish finish,
                             bool check_intersections);

}  // namespace touchmend::geometry
