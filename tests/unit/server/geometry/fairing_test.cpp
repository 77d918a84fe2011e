#include "server/geometry/fairing.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <set>

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
  std::vector<FaceHandle> faces;  //!< the patch
};

CapFill flat_cap_fill() {
  const MeshSoup s = testing::remove_faces(testing::uv_sphere(1.0, 48, 32),
                                           [](const Vec3& c) { return c[2] > 0.8; });
  CapFill out{build_mesh(s).mesh, {}, {}};
  const auto holes = find_holes(out.mesh).holes;
  FillOptions o;
  o.shape = PatchShape::Flat;
  const auto r = fill_hole(out.mesh, holes.at(0), o);
  EXPECT_TRUE(r.filled) << r.reason;
  out.free = r.new_vertices;
  out.faces = r.new_faces;
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

// The small thin plate's dense system is summed straight from the operator's rows in the
// sparse product's order: the faired points are those of the sparse assembly bit for bit, with
// and without a base surface.
TEST(Fairing, DirectDenseAssemblyIsTheSparseProductBitForBit) {
  for (const int rings : {0, 2}) {
    CapFill direct = flat_cap_fill();
    CapFill sparse = flat_cap_fill();
    ASSERT_FALSE(direct.free.empty());
    ASSERT_LE(direct.free.size(), 128u);  // solved dense
    FairingOptions o;
    o.base_fit_rings = rings;
    ASSERT_TRUE(fair_vertices(direct.mesh, direct.free, o).ok);
    o.direct_dense_assembly = false;
    ASSERT_TRUE(fair_vertices(sparse.mesh, sparse.free, o).ok);
    ASSERT_EQ(direct.free, sparse.free);
    for (const VertexHandle v : direct.free)
      for (int c = 0; c < 3; ++c) EXPECT_EQ(direct.mesh.point(v)[c], sparse.mesh.point(v)[c]);
  }
}

TEST(Fairing, SurroundingsOnASphereAreContinuedExactly) {
  CapFill plain = flat_cap_fill();
  FairingOptions no_base;
  no_base.base_fit_rings = 0;
  ASSERT_TRUE(fair_vertices(plain.mesh, plain.free, no_base).ok);
  const double plain_error = max_radius_error(plain.mesh, plain.free);
  EXPECT_GT(plain_error, 1e-4);  // the thin plate flattens the cap

  CapFill f = flat_cap_fill();
  FairingOptions on_the_fit;
  on_the_fit.match_facet_offset = false;
  const FairingReport r = fair_vertices(f.mesh, f.free, on_the_fit);
  ASSERT_TRUE(r.ok) << r.failure;
  EXPECT_EQ(r.base_surface, "sphere");
  EXPECT_LT(max_radius_error(f.mesh, f.free), 1e-9);
}

//! Area-weighted mean of the radial deviation (|x| - 1) over triangles, by their edge
//! midpoints.
double mean_midpoint_deviation(const Mesh& m, const std::vector<FaceHandle>& faces) {
  double area = 0, sum = 0;
  for (const FaceHandle f : faces) {
    std::vector<Vec3> p;
    for (const auto v : m.fv_range(f)) p.push_back(m.point(v));
    const double a = 0.5 * OpenMesh::cross(p[1] - p[0], p[2] - p[0]).norm();
    double mean = 0;
    for (int i = 0; i < 3; ++i) mean += (0.5 * (p[i] + p[(i + 1) % 3])).norm() - 1.0;
    area += a;
    sum += a * mean / 3.0;
  }
  return sum / area;
}

TEST(Fairing, PatchTrianglesSitAsFarFromTheSphereAsTheSurroundingOnes) {
  CapFill f = flat_cap_fill();
  std::vector<char> in_patch(f.mesh.n_faces(), 0);
  for (const FaceHandle g : f.faces) in_patch[static_cast<std::size_t>(g.idx())] = 1;
  FairingOptions options;
  options.in_patch = [&](FaceHandle g) { return in_patch[static_cast<std::size_t>(g.idx())] != 0; };
  const FairingReport r = fair_vertices(f.mesh, f.free, options);
  ASSERT_TRUE(r.ok) << r.failure;
  EXPECT_EQ(r.base_surface, "sphere");
  // Off the sphere by a bump that vanishes towards the fixed rim (a clamped plate under a
  // uniform load), nowhere by more than the sag of the patch's longest edge (l^2 / 8).
  double longest = 0;
  for (const FaceHandle g : f.faces)
    for (const auto h : f.mesh.fh_range(g)) longest = std::max(longest, f.mesh.calc_edge_length(h));
  double deepest = 0, next_to_rim = 0;
  for (const auto v : f.free) {
    const double d = std::abs(f.mesh.point(v).norm() - 1.0);
    deepest = std::max(deepest, d);
    bool on_rim = false;
    for (const auto w : f.mesh.vv_range(v))
      on_rim = on_rim || std::find(f.free.begin(), f.free.end(), w) == f.free.end();
    if (on_rim) next_to_rim = std::max(next_to_rim, d);
  }
  EXPECT_GT(deepest, 1e-6);
  EXPECT_LT(deepest, longest * longest / 8);
  EXPECT_LT(next_to_rim, deepest);
  // The surroundings the fit used: the faces within two rings of the free vertices, outside
  // the patch. Their triangles and the patch's lie at the same mean deviation (to 0.1%: the
  // sphere's curvature leaves a second-order rest after two steps).
  std::set<int> near{};
  std::vector<VertexHandle> ring(f.free.begin(), f.free.end());
  for (const auto v : ring) near.insert(v.idx());
  for (int r2 = 0; r2 < 2; ++r2) {
    std::vector<VertexHandle> next;
    for (const auto v : ring)
      for (const auto w : f.mesh.vv_range(v))
        if (near.insert(w.idx()).second) next.push_back(w);
    ring = next;
  }
  std::vector<FaceHandle> surroundings;
  for (const auto g : f.mesh.faces()) {
    if (in_patch[static_cast<std::size_t>(g.idx())]) continue;
    bool inside = true;
    for (const auto v : f.mesh.fv_range(g)) inside = inside && near.count(v.idx()) > 0;
    if (inside) surroundings.push_back(g);
  }
  ASSERT_FALSE(surroundings.empty());
  EXPECT_NEAR(mean_midpoint_deviation(f.mesh, f.faces),
              mean_midpoint_deviation(f.mesh, surroundings), 1e-6);
}

//! A 16x16 grid over the graph of \p height with a round hole of radius 4, filled flat (the
//! spanning triangulation, refined): the new vertices are what fairing moves. Not mended: the
//! quadric base is a height field over the least-squares plane of the fixed vertices near the
//! free ones, which is the paraboloid's own plane only while that set is symmetric about its
//! axis, as the refined patch's is (a mended patch can leave a rim vertex with no free
//! neighbour, and the fit is then close, not exact).
CapFill flat_grid_fill(const std::function<double(double, double)>& height) {
  CapFill out{build_mesh(testing::grid_with_round_hole(height)).mesh, {}, {}};
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
  FairingOptions on_the_fit;
  on_the_fit.match_facet_offset = false;
  const FairingReport r = fair_vertices(f.mesh, f.free, on_the_fit);
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
