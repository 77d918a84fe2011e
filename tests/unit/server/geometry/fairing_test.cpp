#include "server/geometry/fairing.h"

#include <cmath>

#include <gtest/gtest.h>

#include "server/geometry/hole_filling.h"
#include "server/geometry/holes.h"
#include "server/geometry/mesh_build.h"
#include "tests/support/mesh_factory.h"

namespace touchmend::geometry {
namespace {

//! Fills a spherical-cap hole flat (refined, not faired) and returns the new vertices.
struct CapFill {
  Mesh mesh;
  std::vector<VertexHandle> free;
};

CapFill flat_cap_fill() {
  const MeshSoup s = testing::remove_faces(testing::uv_sphere(1.0, 48, 32),
                                           [](const Vec3& c) { return c[2] > 0.8; });
  CapFill out{build_mesh(s).mesh, {}};
  const auto holes = find_holes(out.mesh).holes;
  FillOptions o;
  o.shape = PatchShape::Flat;
  const auto r = fill_hole(out.mesh, holes.at(0), o);
  EXPECT_TRUE(r.filled) << r.reason;
  out.free = r.new_vertices;
  return out;
}

double max_radius_error(const Mesh& m, const std::vector<VertexHandle>& vs) {
  double e = 0;
  for (const auto v : vs) e = std::max(e, std::abs(m.point(v).norm() - 1.0));
  return e;
}

TEST(Fairing, BiLaplacianRestoresTheSphereCap) {
  CapFill f = flat_cap_fill();
  ASSERT_FALSE(f.free.empty());
  const double flat_error = max_radius_error(f.mesh, f.free);
  const FairingReport r = fair_vertices(f.mesh, f.free);
  ASSERT_TRUE(r.ok) << r.failure;
  const double fair_error = max_radius_error(f.mesh, f.free);
  EXPECT_LT(fair_error, 0.25 * flat_error);
  EXPECT_LT(fair_error, 0.025);  // the 48x32 sphere itself deviates by up to 0.002
}

TEST(Fairing, UniformWeightsAndMembraneAlsoSolve) {
  for (const auto weights : {FairingWeights::Uniform, FairingWeights::Cotangent})
    for (int continuity : {0, 1, 2}) {
      CapFill f = flat_cap_fill();
      FairingOptions options;
      options.continuity = continuity;
      options.weights = weights;
      const FairingReport r = fair_vertices(f.mesh, f.free, options);
      EXPECT_TRUE(r.ok) << r.failure;
      for (const auto v : f.free) EXPECT_TRUE(std::isfinite(f.mesh.point(v)[0]));
    }
}

TEST(Fairing, NothingToFairIsFine) {
  Mesh m;
  EXPECT_TRUE(fair_vertices(m, {}).ok);
}

}  // namespace
}  // namespace touchmend::geometry
