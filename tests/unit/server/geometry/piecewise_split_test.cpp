// The piecewise split (piecewise_split.h) on a loop that no single plane takes: a band's border
// around 300° of a cylinder. A piece larger than the 3D triangulation's limit must be split; when
// none of each vertex's nearest candidates is clear of the mesh (here: a clearance callback that
// refuses every chord shorter than the band is tall, as a body between near vertices would), the
// wider search finds a longer chord and the hole still closes.

#include "server/geometry/piecewise_split.h"

#include <cmath>
#include <numbers>
#include <set>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

namespace touchmend::geometry {
namespace {

//! The border of the band |z| <= h over angles [0, 300°] of the unit cylinder, as a hole loop
//! (top edge forwards, bottom edge back), with the band's own surface outside it.
struct BandLoop {
  std::vector<Vec3> loop, opposite, normals;
};

BandLoop band_loop(int per_side, double h) {
  BandLoop b;
  const double span = 300.0 * std::numbers::pi / 180.0;
  const auto at = [](double a, double z) { return Vec3(std::cos(a), std::sin(a), z); };
  for (int k = 0; k < per_side; ++k) {  // top, angle rising
    const double a = span * k / (per_side - 1);
    b.loop.push_back(at(a, h));
  }
  for (int k = per_side - 1; k >= 0; --k) {  // bottom, angle falling
    const double a = span * k / (per_side - 1);
    b.loop.push_back(at(a, -h));
  }
  const std::size_t n = b.loop.size();
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3& p = b.loop[i];
    b.normals.push_back(Vec3(p[0], p[1], 0).normalize_cond());
    // The mesh across each boundary edge: farther from the band's middle (above the top edge,
    // below the bottom one, beyond the ends).
    const Vec3 mid = 0.5 * (p + b.loop[(i + 1) % n]);
    b.opposite.push_back(
        mid +
        Vec3(0, 0,
             mid[2] > 1e-9    ? 0.2
             : mid[2] < -1e-9 ? -0.2
                              : 0) +
        (std::abs(mid[2]) < 1e-9 ? 0.2 * Vec3(mid[1], -mid[0], 0) : Vec3(0, 0, 0)));
  }
  return b;
}

TEST(Piecewise, APieceTooLargeForTheTriangulationIsSplitByAWiderSearch) {
  const double h = 0.3;
  const BandLoop band = band_loop(30, h);  // 60 vertices
  const double edge = (band.loop[1] - band.loop[0]).norm();
  PiecewiseInput in;
  in.loop = band.loop;
  in.opposite = band.opposite;
  in.vertex_normals = band.normals;
  in.mean_edge_length = edge;
  // Chords up to 1.6 band heights pass through "the body"; longer ones are clear.
  in.chord_clearance = [&](int, int, const Vec3& a, const Vec3& b) {
    return (b - a).norm() < 1.6 * 2 * h ? 0.0 : edge;
  };
  PiecewiseOptions options;
  options.max_dp_vertices = 40;  // the 60-vertex loop cannot go to the DP unsplit
  const PiecewiseResult wide = triangulate_piecewise(in, options);
  ASSERT_TRUE(wide.ok) << wide.failure;
  EXPECT_GE(wide.pieces, 2u);
  // Every boundary edge is used by exactly one triangle, every other edge by two: a closed disk.
  std::multiset<std::pair<int, int>> directed;
  for (const auto& t : wide.triangles)
    for (int k = 0; k < 3; ++k) directed.emplace(t[k], t[(k + 1) % 3]);
  const int n = static_cast<int>(band.loop.size());
  for (const auto& [a, b] : directed) {
    const bool boundary = a < n && b < n && (b == (a + 1) % n);
    EXPECT_EQ(directed.count({a, b}), 1u);
    EXPECT_EQ(directed.count({b, a}), boundary ? 0u : 1u) << a << "-" << b;
  }
  // Before the wider search (only each vertex's eight nearest), the piece was left unsplit and
  // the triangulation refused it.
  options.wide_candidates_per_vertex = options.candidates_per_vertex;
  const PiecewiseResult narrow = triangulate_piecewise(in, options);
  EXPECT_FALSE(narrow.ok);
}

}  // namespace
}  // namespace touchmend::geometry
