// The Hermite curve of sharp-edge retaining (seed 000 §4.2.1 eq. (1)): end points and tangents,
// the straight configuration, the arc-consistent default tangent length, arc-length sampling and
// the refusal of point sets that define no curve.

#include "server/geometry/hermite_curve.h"

#include <cmath>
#include <limits>
#include <numbers>

#include <gtest/gtest.h>

namespace touchmend::geometry {
namespace {

TEST(HermiteCurve, InterpolatesEndsAndTangents) {
  const HermitePoints p{{-1, 0, 0}, {0, 0, 0}, {2, 1, 0}, {2, 3, 0}};
  HermiteOptions options;
  options.k1 = 1.5;
  options.k4 = 2.5;
  const HermiteCurveResult r = make_hermite_curve(p, options, 1e-12);
  ASSERT_TRUE(r.curve) << r.failure;
  const HermiteCurve& c = *r.curve;
  EXPECT_LT((c.at(0) - p.p2).norm(), 1e-15);
  EXPECT_LT((c.at(1) - p.p3).norm(), 1e-15);
  EXPECT_LT((c.derivative(0) - Vec3(1.5, 0, 0)).norm(), 1e-12);  // k1 · unit(P2 - P1)
  EXPECT_LT((c.derivative(1) - Vec3(0, 2.5, 0)).norm(), 1e-12);  // k4 · unit(P4 - P3)
  EXPECT_DOUBLE_EQ(r.k1, 1.5);
  EXPECT_DOUBLE_EQ(r.k4, 2.5);
}

// A piece of a curve (end_on_paired_curves splits a pair's curve at a corner): the same points
// over [0, 1], either way round.
TEST(HermiteCurve, APieceIsTheSamePointsReparametrised) {
  const HermitePoints p{{-1, 0, 0}, {0, 0, 0}, {2, 1, 0}, {2, 3, 1}};
  const HermiteCurveResult r = make_hermite_curve(p, {}, 1e-12);
  ASSERT_TRUE(r.curve) << r.failure;
  const HermiteCurve& c = *r.curve;
  const HermiteCurve ahead = sub_curve(c, 0.0, 0.3);
  const HermiteCurve back = sub_curve(c, 1.0, 0.3);
  for (double s = 0; s <= 1.0; s += 0.125) {
    EXPECT_LT((ahead.at(s) - c.at(0.3 * s)).norm(), 1e-12) << s;
    EXPECT_LT((back.at(s) - c.at(1.0 - 0.7 * s)).norm(), 1e-12) << s;
  }
  EXPECT_LT((back.derivative(0) + 0.7 * c.derivative(1)).norm(), 1e-12);
}

TEST(HermiteCurve, StraightConfigurationGivesTheSegmentAtUniformSpeed) {
  const HermitePoints p{{-1, 1, 1}, {0, 1, 1}, {4, 1, 1}, {5, 1, 1}};
  const HermiteCurveResult r = make_hermite_curve(p, {}, 1e-12);
  ASSERT_TRUE(r.curve);
  EXPECT_DOUBLE_EQ(r.k1, 4.0);  // the chord
  for (double t = 0; t <= 1.0; t += 0.125)
    EXPECT_LT((r.curve->at(t) - Vec3(4 * t, 1, 1)).norm(), 1e-12) << t;
  EXPECT_NEAR(curve_length(*r.curve), 4.0, 1e-9);
}

TEST(HermiteCurve, DefaultTangentLengthFollowsACircularArc) {
  // Quarter circle of radius 2 around the origin from (2, 0) to (0, 2).
  const HermitePoints p{{2, -1, 0}, {2, 0, 0}, {0, 2, 0}, {-1, 2, 0}};
  const HermiteCurveResult r = make_hermite_curve(p, {}, 1e-12);
  ASSERT_TRUE(r.curve);
  double worst = 0;
  for (int i = 0; i <= 64; ++i)
    worst = std::max(worst, std::abs(r.curve->at(i / 64.0).norm() - 2.0));
  EXPECT_LT(worst, 2e-3 * 2.0);  // a cubic quarter arc is within 0.03% of the circle
  // The thesis' chord-length rule would bulge: tangent length = chord.
  HermiteOptions chord;
  chord.k1 = chord.k4 = (p.p3 - p.p2).norm();
  const auto plain = make_hermite_curve(p, chord, 1e-12);
  double plain_worst = 0;
  for (int i = 0; i <= 64; ++i)
    plain_worst = std::max(plain_worst, std::abs(plain.curve->at(i / 64.0).norm() - 2.0));
  EXPECT_GT(plain_worst, worst);
}

TEST(HermiteCurve, SamplesAtEqualArcLength) {
  const HermitePoints p{{2, -1, 0}, {2, 0, 0}, {0, 2, 0}, {-1, 2, 0}};
  const auto r = make_hermite_curve(p, {}, 1e-12);
  ASSERT_TRUE(r.curve);
  const double length = curve_length(*r.curve);
  const auto samples = sample_by_arc_length(*r.curve, 0.3);
  ASSERT_EQ(samples.size(), static_cast<std::size_t>(std::lround(length / 0.3)) + 1);
  EXPECT_LT((samples.front().point - p.p2).norm(), 1e-15);
  EXPECT_LT((samples.back().point - p.p3).norm(), 1e-15);
  const double expected = length / static_cast<double>(samples.size() - 1);
  for (std::size_t i = 1; i < samples.size(); ++i) {
    EXPECT_GT(samples[i].t, samples[i - 1].t);
    EXPECT_NEAR((samples[i].point - samples[i - 1].point).norm(), expected, 0.01 * expected);
  }
  EXPECT_EQ(sample_by_arc_length(*r.curve, 100.0).size(), 2u);  // at least one segment
}

TEST(HermiteCurve, RefusesPointsWithoutDirection) {
  const Vec3 a(0, 0, 0), b(1, 0, 0), c(2, 0, 0), d(3, 0, 0);
  EXPECT_FALSE(make_hermite_curve({a, a, c, d}, {}, 1e-9).curve);
  EXPECT_FALSE(make_hermite_curve({a, b, c, c}, {}, 1e-9).curve);
  EXPECT_FALSE(make_hermite_curve({a, b, b, d}, {}, 1e-9).curve);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const auto r = make_hermite_curve({a, b, Vec3(nan, 0, 0), d}, {}, 1e-9);
  EXPECT_FALSE(r.curve);
  EXPECT_NE(r.failure.find("finite"), std::string::npos);
  HermiteOptions negative;
  negative.k1_scale = -1;
  EXPECT_FALSE(make_hermite_curve({a, b, c, d}, negative, 1e-9).curve);
}

}  // namespace
}  // namespace touchmend::geometry
