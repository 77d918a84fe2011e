#pragma once

//! \file sharp_edges.h
//! \brief Creases across a hole, found with no device: the sharp edges that enter and leave a
//! hole, paired into Hermite curves (seed 000 §4.2.1) or extended to a common corner, and the
//! split of the hole along those curves into pieces that are filled on their own (the variant of
//! ALGORITHMS.md §3.5, after Ngo & Lee 2011): the crease is in the patch by construction.
//!
//! \details Beyond the thesis, whose four points are picked by hand (§4.1). Detection: an edge
//! whose faces meet at more than `crease_angle_deg` is sharp (over `clean_crease_angle_deg` when
//! it stands out from the bends around it, as a CAD part's chamfers do); from every hole boundary
//! vertex with a sharp edge the crease polyline is traced away from the hole (straightest sharp
//! continuation) and its tangent at the boundary is fitted by least squares on a quadratic in
//! arc length, so a curved crease keeps its curvature's first order. A crossing counts when that
//! tangent, continued into the hole, lies inside the hole's corner at the boundary vertex.
//! Pairing: two crossings whose tangents agree with the chord between them (each within
//! `pair_angle_deg`) are joined by the Hermite curve P1 P2 -> P3 P4; three or more crossings left
//! over meet at the least-squares intersection of their tangent lines (a corner, e.g. a cube
//! corner cut by the hole) unless a pair's curve separates them; two left over (or more that
//! cannot meet) are joined if their tangents are at least `loose_pair_angle_deg` consistent.
//! Two still left whose creases bound one planar face of a CAD part are one crease, the face's
//! edge, and are joined however far it turns inside the hole (up to a U; a tongue's end).
//! Everything not joined is reported.
//!
//! Curved creases: the fit also gives each crease's curvature at the rim. Two crossings whose
//! tangents turn by more than `min_arc_turn_deg` between them are joined by a circular arc when
//! both creases bend as that arc does (curvature within `arc_curvature_factor`, towards its
//! centre): the rim of a bore or a boss that the hole cuts across, which may turn by far more
//! than the half turn a cubic Hermite curve can follow (couplingdown_sharp #1: a bore's rim
//! turning 286° inside the hole).
//!
//! Creases along the rim: a crease whose tangent does not enter the hole where it meets the rim
//! may follow rim edges and cross the hole from a later boundary vertex, which has no sharp edge
//! of its own (a boss's top edge the hole cuts short). The rim is followed while each next
//! boundary vertex lies on the crease's continuation (tangent and curvature fitted by the rim,
//! within a quarter edge); where the rim turns away the crease crosses, unless it goes on
//! outside the hole there. Such a crossing pairs along an arc (of at least
//! `rim_run_min_arc_turn_deg`), along the chord when both tangents lie on it (a straight crease
//! crossing a notch, which the plain fill spans on the crease already), or by a Hermite curve
//! like any other pair (a crease that bends and then runs straight, which no arc fits). Of two
//! pairs whose curves meet inside the hole only the better is joined: the split along both
//! would not be manifold.

#include <array>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "server/geometry/face_normals.h"
#include "server/geometry/hermite_curve.h"
#include "server/geometry/holes.h"
#include "server/geometry/mesh.h"

namespace touchmend::geometry {

struct CreaseOptions {
  double crease_angle_deg = 50;      //!< an edge whose faces meet at more than this is sharp
  double pair_angle_deg = 35;        //!< tangent vs chord, both ends, for a clean pair
  double loose_pair_angle_deg = 65;  //!< the same for the last two crossings left over
  //! A weaker sharp edge (over this angle) may continue a crease whose other end is sharp.
  double partner_angle_deg = 30;
  //! A crossing this sharp counts as strong too when its crease stands out cleanly: it goes on
  //! over at least two sharp edges and every other edge at its boundary vertex bends by at most
  //! `clean_crease_ratio` of it. A CAD part's 45° chamfers (couplingdown) are clean; a scan's
  //! lone 46° edge beside a 76° one (the rocker arm) is not.
  double clean_crease_angle_deg = 40;
  double clean_crease_ratio = 1.0 / 3.0;
  //! Two strong crossings pair only if the sharper bends by at most this factor of the other:
  //! a crease keeps its angle along its length (couplingdown_sharp #2: a 90° box edge does not
  //! go on as a 45° chamfer's edge). A weak partner (`partner_angle_deg`) is not held to it.
  double max_pair_dihedral_ratio = 1.5;
  //! Three or more creases meet at a corner only if their tangent lines pass within this
  //! fraction of the hole diameter of a common point.
  double corner_tolerance = 0.1;
  //! A crease left over ends at a rim vertex that a crease reaches from outside (the cut went
  //! through a corner of the part) when its tangent line, seen from its crossing, points at that
  //! vertex within this angle (and passes within `corner_tolerance` of it). A CAD part's
  //! straight creases point at their corners within 0.1°; measured 2026-11-26 on random cuts,
  //! tangents 5–35° off a vertex were a scan's rough creases or a crease that only passes near
  //! it, and their curves made fills farther from the removed surface.
  double rim_corner_angle_deg = 5;
  //! Four or more creases left over meet at two corners joined by a straight crease instead of
  //! one only when the tangent lines pass at most this fraction as far from those corners.
  double two_corner_gain = 0.5;
  //! Arc length of the crease used for the tangent fit, in hole diameters (perimeter / π).
  double fit_length = 0.5;
  //! A pair whose tangents turn by at least this between the crossings may be joined by a
  //! circular arc (below it the straight pairing above decides, and a Hermite curve joins).
  double min_arc_turn_deg = 60;
  //! The same for a pair with a crossing whose crease ran along the rim first (a ring that runs
  //! along the rim and then cuts across turns less inside the hole).
  double rim_run_min_arc_turn_deg = 30;
  //! An arc joins two crossings only if the curvature fitted to each crease is within this
  //! factor of the arc's either way (and bends towards the arc's centre): the fit over a few
  //! edges of a scanned or coarsely meshed rim is rough, but a straight crease (no curvature)
  //! never passes. Below 1 disables arcs.
  double arc_curvature_factor = 2.0;
  HermiteOptions hermite;
  //! Fair each region between the curves on its own (bi-Laplacian, the other regions treated
  //! as absent; a patch that would then intersect the mesh stays flat), or keep it flat. Unset:
  //! as the fill's shape says, and with the auto shape flat on piecewise-planar surroundings
  //! (a CAD part) and faired on curved ones (a scanned part; README "Sharp edges").
  std::optional<bool> fair_pieces;
};

//! Where a crease of the surrounding surface meets the hole boundary.
struct CreaseCrossing {
  std::size_t loop_index = 0;  //!< index into Hole::loop
  VertexHandle vertex;
  Vec3 position{0, 0, 0};
  Vec3 inward{0, 0, 0};  //!< unit tangent continuing the crease into the hole
  //! Curvature vector of the crease at the rim (κ times the unit normal towards the centre of
  //! its osculating circle), fitted nearer the rim than `inward` (kCurvatureFitShare of it).
  Vec3 curvature{0, 0, 0};
  //! The inward tangent of the same fit as `curvature` (nearer the rim than `inward`): the crease
  //! continued into the hole along its osculating circle starts along it. Zero where the
  //! crossing has no fit (`inward` is used then).
  Vec3 bend_inward{0, 0, 0};
  //! The crease's first points from the rim (position first) over which the curvature was
  //! fitted: a circular arc through two crossings is fitted to both ends' points.
  std::vector<Vec3> near_rim;
  Vec3 far_point{0, 0, 0};  //!< a point on the tangent line outside the hole (P1 or P4)
  //! A point on the traced crease itself, the fit length along it from the rim (or its end):
  //! where an operator feeling along the crease would pick P1 or P4.
  Vec3 on_crease{0, 0, 0};
  double dihedral_deg = 0;  //!< at the sharp edge leaving the boundary vertex
  bool convex = false;      //!< the two faces fold away from each other (a ridge)
  //! Unit normals of the two faces of that sharp edge (zero where unknown): the surfaces the
  //! crease parts, whatever the rim's triangles beside its vertex belong to.
  std::array<Vec3, 2> faces{Vec3(0, 0, 0), Vec3(0, 0, 0)};
  //! The largest bend of the other edges at the boundary vertex (degrees; rim edges excluded).
  double other_bends_deg = 0;
  std::size_t traced_edges = 0;
  //! Rim edges the crease runs along before it crosses (0: it crosses where it meets the rim).
  std::size_t rim_run = 0;
};

//! A circular arc from `start` turning by `angle` radians: centre + cos φ·(start − centre) +
//! sin φ·radius·start_direction, φ in [0, angle].
struct CreaseArc {
  Vec3 centre{0, 0, 0};
  Vec3 start{0, 0, 0};
  Vec3 start_direction{0, 0, 0};  //!< unit tangent at start
  double radius = 0;
  double angle = 0;

  Vec3 at(double t) const;  //!< t in [0, 1]
  double length() const { return radius * angle; }
};

//! The circular arc from crossing \p a to crossing \p b that both creases continue into the hole,
//! or none: when the tangents turn by less than \p min_turn_deg (a straight pairing), or the arc
//! does not leave along a's tangent and arrive along b's (within \p max_angle_deg), or a fitted
//! curvature differs from the arc's by more than the factor \p curvature_factor either way
//! or bends away from its centre. \p score receives the angle between b's tangent and the arc's
//! arrival.
std::optional<CreaseArc> crease_arc_between(const CreaseCrossing& a, const CreaseCrossing& b,
                                            double min_turn_deg, double max_angle_deg,
                                            double curvature_factor, double* score = nullptr);

//! The least turn for which crossings \p a and \p b may be joined by an arc: `min_arc_turn_deg`,
//! or `rim_run_min_arc_turn_deg` when either crease ran along the rim first (the automatic plan
//! and picked points alike).
double min_arc_turn_deg(const CreaseOptions& options, const CreaseCrossing& a,
                        const CreaseCrossing& b);

//! One feature curve through the hole: between two crossings, or from a crossing to a corner.
struct CreaseCurve {
  std::size_t from = 0;           //!< crossing index
  std::optional<std::size_t> to;  //!< crossing index; none: ends at the plan's corner `corner`
  std::size_t corner = 0;         //!< index into HoleCreasePlan::corners when `to` is none
  HermitePoints points;           //!< P1..P4 of the curve (seed 000 Fig. 4.2)
  HermiteCurve curve;
  //! A curved crease's arc (crease_arc_between): when set, the curve through the hole is this
  //! arc, and `curve` the Hermite curve of the same four points (for a preview that draws one).
  std::optional<CreaseArc> arc;
  //! How far the pair's tangents stray from the curve joining them (radians; the larger of the
  //! two ends, as the plan ranked the pairs); 0 for a crease that ends at a corner.
  double misfit = 0;
};

struct HoleCreasePlan {
  std::vector<CreaseCrossing> crossings;
  std::vector<CreaseCurve> curves;
  //! Where creases meet inside the hole: one corner (a cube corner cut away), or two to four
  //! in a row joined by straight creases (corner_links), each with the creases from the rim
  //! that end there.
  std::vector<Vec3> corners;
  std::vector<std::pair<std::size_t, std::size_t>> corner_links;
  //! Pairs whose curve a corner splits in two (a crease left over that ends on it): the plan
  //! without its corners (plan_without_corners) has them back whole.
  std::vector<CreaseCurve> pairs_split_at_corners;
  std::vector<std::size_t> unmatched;  //!< crossings that no curve uses
  std::string summary;                 //!< one line for reports
};

//! The arc length over which a crease's tangent is fitted at a hole of \p perimeter: \p
//! fit_length hole diameters (CreaseOptions::fit_length), at least 2.5 \p mean_edge_length.
double crease_fit_length(double perimeter, double mean_edge_length, double fit_length);

//! The creases at the boundary of \p hole (properties computed) and how they cross it.
HoleCreasePlan plan_hole_creases(const Mesh& mesh, const Hole& hole,
                                 const CreaseOptions& options = {});

//! The same, with the face normals of the mesh around the hole read from (and added to) \p
//! normals: a fill decides the patch's shape from the same faces first, and may pass the
//! median_dihedral_near it found there as \p median_dihedral_deg (worked out when needed
//! otherwise).
HoleCreasePlan plan_hole_creases(FaceNormals& normals, const Hole& hole,
                                 const CreaseOptions& options = {},
                                 std::optional<double> median_dihedral_deg = std::nullopt);

//! " meeting at a corner", " meeting at N corners", or nothing for none: for plan summaries.
std::string meeting_at_corners(std::size_t corners);

//! The curves a split along \p plan follows: its creases and the straight links between its
//! corners.
inline std::size_t curve_count(const HoleCreasePlan& plan) {
  return plan.curves.size() + plan.corner_links.size();
}

class FaceNormals;

//! Median dihedral angle (degrees) of the edges within two rings of the hole's boundary. A CAD
//! part's neighbourhood is mostly exactly coplanar pairs (median ~0), a scanned or organic
//! surface bends a little at every edge (median of several degrees on the shared cases).
double median_dihedral_near(const Mesh& mesh, const Hole& hole, FaceNormals& normals);

//! The plan with one curve taken out, for a crease split that could not be made with them all.
//! Where its patch went wrong (\p failed_at: a point of a face that crossed the mesh, or of a
//! triangle that could not be linked into it), the curve nearest that point: the split's trouble
//! is in the regions beside it. Otherwise the least certain curve: a pair joined only loosely
//! (tangents over `options.pair_angle_deg` off its curve) first, the one that strays most; else
//! the corners; else the pair that strays most. A corner's crease or link takes the corners
//! with every crease and link to them. The crossings it used are reported unmatched. None when
//! no curve would be left.
std::optional<HoleCreasePlan> plan_without_weakest_curve(
    const HoleCreasePlan& plan, const CreaseOptions& options = {},
    const std::optional<Vec3>& failed_at = std::nullopt);

//! The plan without its corners (every corner crease and link), as plan_without_weakest_curve
//! leaves them out; none when it has no corners or no curve would be left.
std::optional<HoleCreasePlan> plan_without_corners(const HoleCreasePlan& plan);

//! Extends the creases of \p crossings (indices into plan.crossings, three or more) to a common
//! corner: the least-squares nearest point to their tangent lines, which must lie ahead of every
//! crossing and within \p line_tolerance of every line. On success appends the corner to
//! plan.corners and one curve per crossing, from it to the corner (arriving as a circular arc
//! would); otherwise leaves \p plan unchanged. \p tolerance is the smallest distance that counts.
bool join_at_corner(HoleCreasePlan& plan, std::span<const std::size_t> crossings,
                    double line_tolerance, const HermiteOptions& hermite, double tolerance);

//! Joins the creases of \p crossings (two or more) inside the hole: two clean ones at a corner
//! where their bent creases meet, off the rim; three or more at one corner (join_at_corner, or
//! where their clean bent creases meet; it must satisfy \p inside_hole) or, four or more, at
//! two corners joined by a straight crease, or, five or more, at three in a row joined by two,
//! or, six or more, at four in a row joined by three; each run of creases contiguous along the
//! loop, its corner where the creases continued with their fitted bend come closest (a middle
//! one also nearest the links from its neighbours at the ends). Each
//! further corner is taken when the creases pass within \p two_corner_gain of the best plan with
//! fewer. A corner that falls within a quarter of a mean rim edge of one of its crossings is on
//! the rim (the cut went through the part's corner): the other creases end at that crossing's
//! vertex, and a link from it to another corner leaves from there (no corner is added for it).
//! Returns false, \p plan unchanged, when none qualifies.
bool join_at_corners(HoleCreasePlan& plan, const Mesh& mesh, const Hole& hole,
                     std::span<const std::size_t> crossings, double line_tolerance,
                     double two_corner_gain, const HermiteOptions& hermite, double tolerance,
                     const std::function<bool(const Vec3&)>& inside_hole);

//! The same, with the face normals around the hole read from (and added to) \p normals, and
//! the median_dihedral_near of the hole asked of \p median_dihedral (only two crossings need
//! it; the crease plan works it out once for all its rules).
bool join_at_corners(HoleCreasePlan& plan, FaceNormals& normals, const Hole& hole,
                     std::span<const std::size_t> crossings, double line_tolerance,
                     double two_corner_gain, const HermiteOptions& hermite, double tolerance,
                     const std::function<bool(const Vec3&)>& inside_hole,
                     const std::function<double()>& median_dihedral);

//! The crease that a pick P1 points at from vertex \p at (P2's or P3's vertex on the rim):
//! the chain of edges sharper than \p angle_deg that leaves \p at, continues straightest and
//! passes within \p tolerance of \p pick. Its tangent at \p at, fitted over \p fit_length of
//! arc length as the automatic plan fits it (pointing along the crease towards the pick), is a
//! truer direction than the chord to the pick: seed 000 §5 found that one pick on a badly
//! oriented triangle biases the whole curve. When no crease leaves \p at towards the pick, one
//! that reaches the rim nearby and runs along it to \p at (each rim vertex on its continuation,
//! as plan_hole_creases follows the rim) is taken. None when no such crease leads to the pick.
std::optional<Vec3> crease_tangent_towards(const Mesh& mesh, VertexHandle at, const Vec3& pick,
                                           double angle_deg, double tolerance, double fit_length);

//! What crease_tangent_towards finds, with the crease's bend there as plan_hole_creases
//! measures it: for picks on a curved crease (a ring), so that two picked ends can be joined by
//! the arc both continue (crease_arc_between) instead of a Hermite curve.
struct CreaseShape {
  Vec3 tangent{0, 0, 0};    //!< unit, from the rim along the crease towards the pick
  Vec3 curvature{0, 0, 0};  //!< κ·N at the rim
  //! The tangent of the same short fit as `curvature`: with it, the crease's osculating circle at
  //! the rim.
  Vec3 bend_tangent{0, 0, 0};
  std::vector<Vec3> near_rim;  //!< the crease's first points from the rim (rim first)
  //! Rim edges the crease runs along before it reaches the vertex (0: it leaves it directly).
  std::size_t rim_run = 0;
};
std::optional<CreaseShape> crease_shape_towards(const Mesh& mesh, VertexHandle at, const Vec3& pick,
                                                double angle_deg, double tolerance,
                                                double fit_length);

//! A hole loop with curves through it, as the split triangulation needs it (points only).
struct CurveSplitInput {
  std::span<const Vec3> loop;      //!< hole on the left of i -> i+1
  std::span<const Vec3> opposite;  //!< third vertex across boundary edge i (midpoint if none)
  std::span<const std::pair<int, int>> blocked;  //!< loop pairs joined by a mesh edge outside
  Vec3 normal{0, 0, 1};  //!< projection direction for the region split (the hole's normal)
  //! Each curve: its ends, a loop index or -1 - k for corner k (a curve from a crossing ends at
  //! the rim or at a corner; a crease between two corners starts at one), and its points
  //! strictly between the ends.
  struct Curve {
    int from = 0;
    int to = -1;
    std::vector<Vec3> interior;
  };
  std::vector<Curve> curves;
  std::vector<Vec3> corners;
  std::size_t max_dp_vertices = 400;
};

struct CurveSplitTriangulation {
  bool ok = false;
  std::string failure;
  std::vector<Vec3> new_points;               //!< pool index = loop.size() + i
  std::vector<std::array<int, 3>> triangles;  //!< pool indices, oriented like the loop
  std::vector<int> piece_of_triangle;         //!< which region each triangle fills
  std::size_t pieces = 0;
  std::vector<std::pair<int, int>> curve_edges;  //!< pool index pairs along the curves
};

//! Splits the hole along the curves (a planar graph traced face by face in the projection along
//! \p normal) and triangulates every region by the 3D minimum-dihedral triangulation (the
//! curve edges count as free, so each side only follows its own neighbours); a region it cannot
//! close falls back to Algorithm II on its own plane.
CurveSplitTriangulation triangulate_along_curves(const CurveSplitInput& input);

//! The curves of \p plan sampled at \p segment_length, as split input curves.
std::vector<CurveSplitInput::Curve> sample_plan_curves(const HoleCreasePlan& plan,
                                                       double segment_length);

}  // namespace touchmend::geometry
