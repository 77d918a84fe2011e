#pragma once

//! \file hermite_curve.h
//! \brief The cubic Hermite curve of sharp-edge retaining (seed 000 §4.2.1, eq. (1);
//! ALGORITHMS.md §3.1): from four points P1..P4 picked along a crease, the curve runs from P2 to
//! P3 leaving P2 along P1->P2 and arriving at P3 along P3->P4.

#include <optional>
#include <string>
#include <vector>

#include "server/geometry/mesh.h"

namespace touchmend::geometry {

struct HermitePoints {
  Vec3 p1, p2, p3, p4;
};

//! Q(t) = (2t³-3t²+1)·A + (-2t³+3t²)·B + (t³-2t²+t)·R_A + (t³-t²)·R_B, t in [0, 1].
struct HermiteCurve {
  Vec3 start{0, 0, 0};          //!< A = P2
  Vec3 end{0, 0, 0};            //!< B = P3
  Vec3 start_tangent{0, 0, 0};  //!< R_A = k1 · unit(P2 - P1)
  Vec3 end_tangent{0, 0, 0};    //!< R_B = k4 · unit(P4 - P3)

  Vec3 at(double t) const;
  Vec3 derivative(double t) const;
};

//! Tangent lengths. The thesis' k = 15 is in its models' units (seed 000 §5.1), so the
//! default here scales with the configuration: k = scale × |P3 - P2| × a(θ), where a(θ) makes
//! the curve a circular arc when the end tangents turn by θ (a = 1 for a straight
//! configuration, which gives the straight segment at uniform speed, ALGORITHMS.md §3.1; a = 2
//! for a U-turn). An absolute k1/k4 (> 0) overrides the scale.
struct HermiteOptions {
  double k1 = 0;  //!< absolute start tangent length; 0 = k1_scale × chord
  double k4 = 0;  //!< absolute end tangent length; 0 = k4_scale × chord
  double k1_scale = 1.0;
  double k4_scale = 1.0;
};

struct HermiteCurveResult {
  std::optional<HermiteCurve> curve;
  std::string failure;  //!< why the four points make no curve
  double k1 = 0, k4 = 0;
};

//! Builds the curve, refusing coincident points (P1 = P2 or P3 = P4 give no direction, P2 = P3
//! no curve) and non-finite input. \p tolerance is the smallest distance that counts.
HermiteCurveResult make_hermite_curve(const HermitePoints& points, const HermiteOptions& options,
                                      double tolerance);

struct CurveSample {
  double t = 0;
  Vec3 point{0, 0, 0};
};

//! Samples at (nearly) equal arc length so that each segment is close to \p segment_length
//! (seed 000 §4.2.1: segments match the boundary edges around the hole). The first and last
//! samples are the end points; at least one segment.
std::vector<CurveSample> sample_by_arc_length(const HermiteCurve& curve, double segment_length);

//! Arc length of the curve (256 chords).
double curve_length(const HermiteCurve& curve);

//! The piece of \p curve from parameter \p from to \p to (either way round) as a curve of its
//! own over [0, 1]: the same points, its tangents scaled by the piece's parameter span.
HermiteCurve sub_curve(const HermiteCurve& curve, double from, double to);

}  // namespace touchmend::geometry
