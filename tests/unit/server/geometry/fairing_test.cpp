#include "server/geometry/fairing.h"

#include <cmath>
#include <functional>

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
  FairingOptions plain;
  plain.base_fit_rings = 0;
  const FairingReport r = fair_vertices(f.mesh, f.free, plain);
  ASSERT_TRUE(r.ok) << r.failure;
  EXPECT_TRUE(r.base_surface.empty());
  const double fair_error = max_radius_error(f.mesh, f.free);
  EXPECT_LT(fair_error, 0.25 * flat_error);
  EXPECT_LT(fair_error, 0.025);  // the 48x32 sphere itself deviates by up to 0.002
}

TEST(Fairing, SurroundingsOnASphereAreContinuedExactly) {
  CapFill plain = flat_cap_fill();
  FairingOptions no_base;
  no_base.base_fit_rings = 0;
  ASSERT_TRUE(fair_vertices(plain.mesh, plain.free, no_base).ok);
  const double plain_error = max_radius_error(plain.mesh, plain.free);
  EXPECT_GT(plain_error, 1e-4);  // the thin plate flattens the cap

  CapFill f = flat_cap_fill();
  const FairingReport r = fair_vertices(f.mesh, f.free);
  ASSERT_TRUE(r.ok) << r.failure;
  EXPECT_EQ(r.base_surface, "sphere");
  EXPECT_LT(max_radius_error(f.mesh, f.free), 1e-9);
}

//! A 16x16 grid over the graph of \p height with a round hole of radius 4, filled flat (the
//! spanning triangulation, refined): the new vertices are what fairing moves. Not mended: the
//! quadric base is a height field over the least-squares plane of the fixed vertices near the
//! free ones, which is the paraboloid's own plane only while that set is symmetric about its
//! axis, as the refined patch's is (a mended patch can leave a rim vertex with no free
//! neighbour, and the fit is then close, not exact).
CapFill flat_grid_fill(const std::function<double(double, double)>& height) {
  CapFill out{build_mesh(testing::grid_with_round_hole(height)).mesh, {}};
  const auto holes = find_holes(out.mesh).holes;
  FillOptions o;
  o.shape = PatchShape::Flat;
  o.improve_quality = false;
  for (const Hole& hole : holes)
    if (hole.loop.size() < 40) {
      const auto r = fill_hole(out.mesh, hole, o);
      EXPECT_TRUE(r.filled) << r.reason;
      out.free = r.new_vertices;
    }
  return out;
}

double max_height_error(const Mesh& m, const std::vector<VertexHandle>& vs,
                        const std::function<double(double, double)>& height) {
  double e = 0;
  for (const auto v : vs) {
    const Vec3& p = m.point(v);
    e = std::max(e, std::abs(p[2] - height(p[0], p[1])));
  }
  return e;
}

TEST(Fairing, SurroundingsOnAQuadricAreContinuedExactly) {
  // An elliptic paraboloid whose axes are not the grid's.
  const auto height = [](double x, double y) {
    return 0.03 * (x - 8) * (x - 8) + 0.08 * (y - 8) * (y - 8) + 0.02 * (x - 8) * (y - 8);
  };
  CapFill plain = flat_grid_fill(height);
  ASSERT_FALSE(plain.free.empty());
  FairingOptions no_base;
  no_base.base_fit_rings = 0;
  ASSERT_TRUE(fair_vertices(plain.mesh, plain.free, no_base).ok);
  EXPECT_GT(max_height_error(plain.mesh, plain.free, height), 1e-3) << "plain fairing";

  CapFill f = flat_grid_fill(height);
  const FairingReport r = fair_vertices(f.mesh, f.free);
  ASSERT_TRUE(r.ok) << r.failure;
  EXPECT_EQ(r.base_surface, "quadric");
  EXPECT_LT(max_height_error(f.mesh, f.free, height), 1e-9);
}

TEST(Fairing, BumpySurroundingsGetPlainFairing) {
  const auto height = [](double x, double y) { return 1.5 * std::sin(1.3 * x) * std::cos(y); };
  CapFill f = flat_grid_fill(height);
  ASSERT_FALSE(f.free.empty());
  const FairingReport r = fair_vertices(f.mesh, f.free);
  ASSERT_TRUE(r.ok) << r.failure;
  EXPECT_TRUE(r.base_surface.empty()) << r.base_surface;
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
