#include "server/geometry/ear_clipping.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <set>

#include <gtest/gtest.h>

namespace touchmend::geometry {
namespace {

struct Polygon {
  std::vector<Vec3> loop, opposite;
};

//! A regular n-gon in z = 0 (counter-clockwise from +z) with coplanar neighbours outside.
Polygon regular(int n) {
  Polygon p;
  for (int i = 0; i < n; ++i)
    p.loop.emplace_back(std::cos(2 * std::numbers::pi * i / n),
                        std::sin(2 * std::numbers::pi * i / n), 0);
  for (int i = 0; i < n; ++i) p.opposite.push_back(0.5 * (p.loop[i] + p.loop[(i + 1) % n]) * 1.5);
  return p;
}

TEST(EarClipping, ClosesAPolygonWithConsistentlyOrientedTriangles) {
  const Polygon p = regular(12);
  EarClippingInput in;
  in.loop = p.loop;
  in.opposite = p.opposite;
  const EarClipping r = clip_ears(in);
  ASSERT_TRUE(r.ok) << r.failure;
  ASSERT_EQ(r.triangles.size(), 10u);
  std::set<std::pair<int, int>> directed;
  for (const auto& t : r.triangles) {
    const Vec3 n = OpenMesh::cross(p.loop[t[1]] - p.loop[t[0]], p.loop[t[2]] - p.loop[t[0]]);
    EXPECT_GT(n[2], 0);          // oriented like the loop
    for (int k = 0; k < 3; ++k)  // no directed edge twice: a manifold disk
      EXPECT_TRUE(directed.insert({t[k], t[(k + 1) % 3]}).second);
  }
}

TEST(EarClipping, GoesAroundTrianglesTheCheckRefuses) {
  // Refuse every ear at vertex 0 and every triangle using the chord 2-6: the ears are cut
  // elsewhere and none of the refused triangles is in the result.
  const Polygon p = regular(8);
  EarClippingInput in;
  in.loop = p.loop;
  in.opposite = p.opposite;
  std::size_t refused = 0;
  const auto bad = [](const std::array<int, 3>& c) {
    std::array<int, 3> s = c;
    std::sort(s.begin(), s.end());
    const bool chord =
        (s[0] == 2 && s[1] == 6) || (s[0] == 2 && s[2] == 6) || (s[1] == 2 && s[2] == 6);
    return c[1] == 0 || chord;
  };
  in.crosses_mesh = [&](const std::array<int, 3>& c) {
    if (!bad(c)) return false;
    ++refused;
    return true;
  };
  const EarClipping r = clip_ears(in);
  ASSERT_TRUE(r.ok) << r.failure;
  EXPECT_GT(refused, 0u);
  EXPECT_EQ(r.triangles.size(), 6u);
  for (const auto& t : r.triangles) EXPECT_FALSE(bad(t));
}

TEST(EarClipping, ReportsWhenEveryEarIsRefused) {
  const Polygon p = regular(6);
  EarClippingInput in;
  in.loop = p.loop;
  in.opposite = p.opposite;
  in.crosses_mesh = [](const std::array<int, 3>&) { return true; };
  const EarClipping r = clip_ears(in);
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.failure.find("no ear"), std::string::npos) << r.failure;
}

}  // namespace
}  // namespace touchmend::geometry
