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

#include "server/geometry/edge_retaining.h"
#include "server/geometry/hole_filling.h"
#include "server/geometry/holes.h"

namespace touchmend::geometry {

enum class SharpenMethod { PushDown, Split };
const char* to_string(SharpenMethod method);

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
};

struct SharpenResult {
  bool ok = false;
  std::string failure;
  HermitePoints points;  //!< the picks, snapped to the surface (P2, P3 onto the boundary for split)
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

//! One line on what a push-down did, for reports: "4 snapped, 2 split, 10 pushed, 43 faired"
//! (or "..., fairing undone: <why>").
std::string push_down_summary(const SharpenResult& result, PushFinish finish);

}  // namespace touchmend::geometry
