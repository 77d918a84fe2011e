#pragma once

//! \file sharpen.h
//! \brief Sharp-edge retaining on one hole from four picked points, without a device: the
//! hole is filled, then either (push-down variant, seed 000 §4.2) the patch is snapped onto the
//! guiding surface (Algorithm V), every curtain vertex is pushed to the Hermite curve or a set
//! depth past it (the end state of Algorithm VI's sweeps) and the rest is smoothed by normal
//! propagation (Algorithm VII); or (split variant, ALGORITHMS.md §3.5) the hole is filled split
//! along the sampled curve, so the crease exists by construction.

#include <optional>
#include <string>
#include <vector>

#include "server/geometry/edge_retaining.h"
#include "server/geometry/hole_filling.h"
#include "server/geometry/holes.h"

namespace touchmend::geometry {

enum class SharpenMethod { PushDown, Split };
const char* to_string(SharpenMethod method);

//! Where the Hermite curve's end tangents come from.
enum class PickTangents {
  //! The thesis' unit(P2 - P1) and unit(P4 - P3) (seed 000 §4.2).
  Chord,
  //! Where P1 (P4) lies on a crease that reaches the rim at P2's (P3's) boundary vertex, that
  //! crease's fitted tangent there (crease_tangent_towards); the chord elsewhere.
  Crease,
};
const char* to_string(PickTangents tangents);
bool parse_pick_tangents(const std::string& text, PickTangents& out);

struct SharpenOptions {
  //! Split by default: closer to the ground truth on every *_sharp case where both apply, and
  //! it never folds the patch (README "Sharp edges"). PushDown is the thesis' tool.
  SharpenMethod method = SharpenMethod::Split;
  HermiteOptions hermite;
  //! How the hole itself is filled first (push-down: always without automatic crease
  //! retaining, whatever `fill.sharp` says, since the picks define the crease).
  FillOptions fill;
  SnapOptions snap;
  double depth = 0;  //!< push past the curve by this much (push-down variant)
  //! Fair by default: after a rounded fill of a cube's edge it lays each side back onto its
  //! face (0.0018 off them, against 0.17 unfinished and 0.28 after Algorithm VII, side 8); on
  //! the *_sharp cases Algorithm VII moved the patch away from the ground truth wherever it
  //! moved anything (README "Sharp edges").
  PushFinish finish = PushFinish::Fair;
  //! Picks farther than this (in hole diameters) from the hole's surroundings are refused.
  double max_pick_distance = 2.0;
  //! Crease by default: seed 000 §5 found that one pick on a badly oriented triangle biases
  //! the curve; the crease the picks point at does not (fandisk_sharp #0 with P1 and P4 one
  //! edge length beside the crease: 0.00‰ off it, the chord 1.9‰; with picks on the crease both
  //! give the same curve except on a corner hole: README "Sharp edges").
  PickTangents tangents = PickTangents::Crease;
  //! PickTangents::Crease: an edge sharper than this may carry the crease (the weaker partner
  //! angle of the automatic plan, so a crease fading towards the hole still counts).
  double crease_angle_deg = 30.0;
  //! PickTangents::Crease: P1 (P4) counts as on the crease within this many mean boundary edge
  //! lengths of it.
  double crease_pick_tolerance = 1.0;
};

struct SharpenResult {
  bool ok = false;
  std::string failure;
  //! The curve's points: the picks snapped to the surface (P2, P3 onto the boundary for split),
  //! P1 (P4) moved onto the crease's tangent line, at the same distance, where it was taken.
  HermitePoints points;
  //! Which ends took the tangent of the crease the picks point at (PickTangents::Crease).
  bool crease_tangent_start = false;
  bool crease_tangent_end = false;
  //! sharpen_creases: where the corner's creases meet, and how many curve ends and corner
  //! creases took their crease's tangent (PickTangents::Crease).
  std::optional<Vec3> corner;
  int crease_tangents_taken = 0;
  //! Split variant, PickTangents::Crease: picked curves joined by the circular arc both ends'
  //! creases continue (a ring) instead of their Hermite curve.
  int arcs = 0;
  std::optional<GuideSurface> guide;
  HoleFillReport fill;
  SnapReport snap;
  std::size_t pushed = 0;
  PushFinishReport finish;        //!< push-down: what the finish did, or why it was undone
  std::vector<FaceHandle> patch;  //!< the hole's faces at the end
};

//! Fills \p hole and retains the sharp edge through P1..P4 (P1, P2 on one side of the hole, P2
//! nearest it; P3, P4 on the other, P3 nearest). On failure the mesh is unchanged apart from
//! deleted elements (collect garbage before export).
SharpenResult sharpen_hole(Mesh& mesh, const Hole& hole, const HermitePoints& picks,
                           const SharpenOptions& options = {});

//! P1 and P4 after PickTangents::Crease, and which ends took a crease's tangent.
struct CreaseTangentPicks {
  HermitePoints points;
  bool start = false;
  bool end = false;
};

//! PickTangents::Crease for picks whose P2 (P3) lies at the rim vertex \p at_p2 (\p at_p3; an
//! invalid handle where none is near) of a hole with \p perimeter and \p mean_edge_length: where
//! P1 (P4) lies on a crease reaching the rim there (crease_tangent_towards, within
//! `crease_pick_tolerance` mean edges, edges sharper than `crease_angle_deg`), it moves onto
//! that crease's tangent line at its distance from P2 (P3), so the curve leaves along the
//! crease. The batch sharpen and the station's interactive tool share it.
CreaseTangentPicks take_crease_tangents(const Mesh& mesh, const HermitePoints& picks,
                                        VertexHandle at_p2, VertexHandle at_p3, double perimeter,
                                        double mean_edge_length, const SharpenOptions& options);

//! One crease picked for a corner inside a hole: a point on it away from the hole (as P1) and
//! one where it reaches the rim (as P2).
struct CreasePick {
  Vec3 far{0, 0, 0};
  Vec3 rim{0, 0, 0};
};

//! What an operator picked for one hole: curves through it (P1..P4 each, as the thesis picks
//! one), and the creases that meet inside it (none, or three or more: at one corner, or at two
//! or three joined by creases, as join_at_corners decides).
struct PickedCreases {
  std::vector<HermitePoints> curves;
  std::vector<CreasePick> corner;
  //! The thesis' pick: one curve and no corner.
  bool one_curve() const { return curves.size() == 1 && corner.empty(); }
};

//! The split variant for any number of picked creases, beyond the thesis (whose one curve P1..P4
//! cannot follow three creases meeting inside a hole, e.g. a box corner cut away). Each curve
//! is taken as sharpen_hole's split takes it; each corner crease's rim pick goes to its nearest
//! boundary vertex, its direction into the hole is the crease's tangent there
//! (PickTangents::Crease, where the far pick lies on a crease from that vertex) or the chord
//! from the far pick, and the corner creases are extended to the point nearest all their tangent
//! lines (join_at_corner, within the automatic plan's corner tolerance). The hole is then filled
//! split along every curve. Every pick reaches the rim at its own boundary vertex. (One curve
//! pushed down is sharpen_hole's.)
SharpenResult sharpen_creases(Mesh& mesh, const Hole& hole, const PickedCreases& picked,
                              const SharpenOptions& options = {});

//! One line on what a push-down did, for reports: "4 snapped, 2 split, 10 pushed, 43 faired"
//! (or "..., fairing undone: <why>").
std::string push_down_summary(const SharpenResult& result, PushFinish finish);

//! One line on where the curve's end directions came from (\p start, \p end: whether P2's and
//! P3's ends took the crease's tangent), for reports: "tangents of the crease at both ends",
//! "... at P2, the chord at P3", "chord tangents".
std::string tangents_summary(bool start, bool end, PickTangents tangents);

//! One line on what sharpen_creases followed, for reports: "1 curve and 3 creases meeting at a
//! corner (8, 8, 8); 5 of 5 along their crease's tangent".
std::string creases_summary(const SharpenResult& result, const PickedCreases& picked,
                            PickTangents tangents);

}  // namespace touchmend::geometry
