#include "server/geometry/hermite_curve.h"

#include <algorithm>
#include <cmath>

namespace touchmend::geometry {
namespace {

constexpr int kLengthTableSize = 256;

bool finite(const Vec3& p) {
  return std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]);
}

//! Cumulative chord length at t = i / kLengthTableSize.
std::vector<double> length_table(const HermiteCurve& curve) {
  std::vector<double> table(kLengthTableSize + 1, 0.0);
  Vec3 previous = curve.at(0);
  for (int i = 1; i <= kLengthTableSize; ++i) {
    const Vec3 p = curve.at(static_cast<double>(i) / kLengthTableSize);
    table[static_cast<std::size_t>(i)] =
        table[static_cast<std::size_t>(i - 1)] + (p - previous).norm();
    previous = p;
  }
  return table;
}

}  // namespace

Vec3 HermiteCurve::at(double t) const {
  const double t2 = t * t, t3 = t2 * t;
  return (2 * t3 - 3 * t2 + 1) * start + (-2 * t3 + 3 * t2) * end +
         (t3 - 2 * t2 + t) * start_tangent + (t3 - t2) * end_tangent;
}

Vec3 HermiteCurve::derivative(double t) const {
  const double t2 = t * t;
  return (6 * t2 - 6 * t) * start + (-6 * t2 + 6 * t) * end + (3 * t2 - 4 * t + 1) * start_tangent +
         (3 * t2 - 2 * t) * end_tangent;
}

HermiteCurveResult make_hermite_curve(const HermitePoints& points, const HermiteOptions& options,
                                      double tolerance) {
  HermiteCurveResult result;
  for (const Vec3& p : {points.p1, points.p2, points.p3, points.p4})
    if (!finite(p)) {
      result.failure = "a picked point is not a finite coordinate";
      return result;
    }
  const Vec3 in = points.p2 - points.p1;
  const Vec3 out = points.p4 - points.p3;
  const double chord = (points.p3 - points.p2).norm();
  if (in.norm() <= tolerance) {
    result.failure = "P1 and P2 coincide: no start direction";
    return result;
  }
  if (out.norm() <= tolerance) {
    result.failure = "P3 and P4 coincide: no end direction";
    return result;
  }
  if (chord <= tolerance) {
    result.failure = "P2 and P3 coincide: nothing to bridge";
    return result;
  }
  // Default tangent length: the one that makes the curve a circular arc when the ends allow
  // one, k = chord · 2 tan(θ/4) / sin(θ/2) with θ the turn from the start to the end tangent
  // (a cubic Bézier arc has its control points at 4/3 tan(θ/4) R, and R = chord / (2 sin(θ/2))).
  // It is the chord itself for a straight configuration (ALGORITHMS.md §3.1's default) and
  // grows to 2 chords for a U-turn.
  const double turn = std::atan2(OpenMesh::cross(in, out).norm(), OpenMesh::dot(in, out));
  const double arc = turn > 1e-6 ? 2.0 * std::tan(turn / 4) / std::sin(turn / 2) : 1.0;
  result.k1 = options.k1 > 0 ? options.k1 : options.k1_scale * arc * chord;
  result.k4 = options.k4 > 0 ? options.k4 : options.k4_scale * arc * chord;
  if (!(result.k1 > 0) || !(result.k4 > 0) || !std::isfinite(result.k1) ||
      !std::isfinite(result.k4)) {
    result.failure = "tangent lengths k1 and k4 must be positive";
    return result;
  }
  HermiteCurve curve;
  curve.start = points.p2;
  curve.end = points.p3;
  curve.start_tangent = result.k1 * in / in.norm();
  curve.end_tangent = result.k4 * out / out.norm();
  result.curve = curve;
  return result;
}

double curve_length(const HermiteCurve& curve) {
  return length_table(curve).back();
}

std::vector<CurveSample> sample_by_arc_length(const HermiteCurve& curve, double segment_length) {
  const std::vector<double> table = length_table(curve);
  const double total = table.back();
  int segments = 1;
  if (segment_length > 0 && std::isfinite(segment_length))
    segments = std::max(1, static_cast<int>(std::lround(total / segment_length)));
  segments = std::min(segments, 4096);
  std::vector<CurveSample> samples;
  samples.push_back({0.0, curve.start});
  std::size_t cell = 0;
  for (int s = 1; s < segments; ++s) {
    const double target = total * s / segments;
    while (cell + 1 < table.size() && table[cell + 1] < target) ++cell;
    const double span = table[cell + 1] - table[cell];
    const double fraction = span > 0 ? (target - table[cell]) / span : 0.0;
    const double t = (static_cast<double>(cell) + fraction) / kLengthTableSize;
    samples.push_back({t, curve.at(t)});
  }
  samples.push_back({1.0, curve.end});
  return samples;
}

HermiteCurve sub_curve(const HermiteCurve& curve, double from, double to) {
  const double span = to - from;
  return {curve.at(from), curve.at(to), span * curve.derivative(from), span * curve.derivative(to)};
}

}  // namespace touchmend::geometry
