// God-object contact on a sphere, a cube (faces, edges, corners), a thin two-sided plate and a
// mesh with a hole: the proxy never goes through the surface, the force points along the
// surface normal, and there is no force without contact. Then the haptic loop on the
// simulated device: force direction, easing in a remote edit, and no allocation on the
// haptic thread.

#include <atomic>
#include <cmath>
#include <new>
#include <numbers>
#include <random>
#include <thread>

#include <gtest/gtest.h>

#include "client/haptics/haptic_loop.h"
#include "client/haptics/proxy_updater.h"
#include "device/simulated_device.h"
#include "tests/support/allocation_probe.h"
#include "tests/support/haptic_meshes.h"

namespace touchmend::haptics {
namespace {

SurfaceMesh sphere(double r, int around, int rings) {
  return testing::uv_sphere_surface(r, around, rings);
}

//! A grid z = 0 over [0, n]² (cell size 1), optionally without the cells in `hole`.
SurfaceMesh plate(int n, const Eigen::AlignedBox2d& hole = Eigen::AlignedBox2d()) {
  SurfaceMesh m;
  for (int y = 0; y <= n; ++y)
    for (int x = 0; x <= n; ++x) m.positions.push_back(Vec3(x, y, 0));
  const auto id = [&](int x, int y) { return std::uint32_t(y * (n + 1) + x); };
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      if (!hole.isEmpty() && hole.contains(Eigen::Vector2d(x + 0.5, y + 0.5))) continue;
      m.triangles.push_back({id(x, y), id(x + 1, y), id(x + 1, y + 1)});
      m.triangles.push_back({id(x, y), id(x + 1, y + 1), id(x, y + 1)});
    }
  return m;
}

//! The cube [-1, 1]³, each face split into n×n cells.
SurfaceMesh cube(int n) {
  SurfaceMesh m;
  for (int axis = 0; axis < 3; ++axis)
    for (int side = -1; side <= 1; side += 2) {
      const auto base = std::uint32_t(m.positions.size());
      const int u = (axis + 1) % 3, v = (axis + 2) % 3;
      for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) {
          Vec3 p;
          p[axis] = side;
          p[u] = -1 + 2.0 * i / n;
          p[v] = -1 + 2.0 * j / n;
          m.positions.push_back(p);
        }
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
          const std::uint32_t a = base + j * (n + 1) + i, b = a + 1, c = a + n + 1, d = c + 1;
          m.triangles.push_back({a, b, d});
          m.triangles.push_back({a, d, c});
        }
    }
  return m;
}

TriangleSet index(const SurfaceMesh& m) {
  TriangleSet s;
  s.build(m);
  return s;
}

double angle_deg(const Vec3& a, const Vec3& b) {
  return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) * 180 /
         std::numbers::pi;
}

TEST(Contact, SphereProxyStaysOutsideAndForceFollowsTheNormal) {
  const SurfaceMesh mesh = sphere(1.0, 48, 24);
  const TriangleSet set = index(mesh);
  // Inscribed polyhedron: every facet is at least this far from the centre.
  const double inner = std::cos(std::numbers::pi / 24) * std::cos(std::numbers::pi / 48);
  std::mt19937 rng(7);
  std::normal_distribution<double> gauss;
  for (int trial = 0; trial < 200; ++trial) {
    const Vec3 dir = Vec3(gauss(rng), gauss(rng), gauss(rng)).normalized();
    GodObject god;
    god.reset(1.5 * dir);
    ContactResult c;
    // Press in to 30% depth, then slide sideways while pressed.
    for (int k = 0; k <= 100; ++k) {
      c = god.update(set, (1.5 - 0.8 * k / 100.0) * dir);
      ASSERT_GE(c.proxy.norm(), inner - 1e-6) << "pop-through, trial " << trial;
    }
    ASSERT_TRUE(c.in_contact);
    const Vec3 goal = 0.7 * dir;
    const Vec3 force_dir = c.proxy - goal;
    EXPECT_LT(angle_deg(force_dir, c.normal), 1e-3);  // along the contact normal
    EXPECT_LT(angle_deg(force_dir, c.proxy), 12.0);   // and close to the radial one
    const Vec3 side = dir.unitOrthogonal();
    for (int k = 1; k <= 200; ++k) {
      const Vec3 g = 0.7 * (dir * std::cos(k * 0.01) + side * std::sin(k * 0.01));
      c = god.update(set, g);
      ASSERT_GE(c.proxy.norm(), inner - 1e-6) << "pop-through while sliding, trial " << trial;
      ASSERT_TRUE(c.in_contact);
    }
  }
  // Outside: no contact, the proxy is the goal (no force).
  GodObject free;
  free.reset(Vec3(2, 0, 0));
  const ContactResult c = free.update(set, Vec3(1.5, 0.3, 0));
  EXPECT_FALSE(c.in_contact);
  EXPECT_EQ(c.proxy, Vec3(1.5, 0.3, 0));
}

bool inside_cube(const Vec3& p, double margin) {
  return p.cwiseAbs().maxCoeff() < 1 - margin;
}

TEST(Contact, CubeFacesEdgesAndCornersDoNotLetThePointThrough) {
  const TriangleSet set = index(cube(3));
  // From outside, pressed in just behind a face, an edge or a corner: the proxy rests on the
  // nearest face (from inside a convex solid that is where the nearest surface point is),
  // never inside, and the force is along that face's normal only.
  const Vec3 outside[] = {Vec3(1.5, 0.2, 0.1),   Vec3(1.5, 1.5, 0.3),   Vec3(1.5, 1.5, 1.5),
                          Vec3(-1.5, -1.5, 1.5), Vec3(0.0, -1.5, -1.5), Vec3(-1.5, 0.5, 0)};
  for (const Vec3& start : outside) {
    GodObject god;
    god.reset(start);
    Vec3 end = start;
    for (int axis = 0; axis < 3; ++axis)
      if (std::abs(start[axis]) > 1) end[axis] = start[axis] > 0 ? 0.9 : -0.9;
    ContactResult c;
    for (int k = 0; k <= 200; ++k) {
      c = god.update(set, start + (end - start) * (k / 200.0));
      ASSERT_FALSE(inside_cube(c.proxy, 1e-6)) << start.transpose();
    }
    EXPECT_TRUE(c.in_contact);
    EXPECT_EQ(c.constraints, 1);
    const Vec3 f = c.proxy - end;
    int normal_axes = 0;
    for (int axis = 0; axis < 3; ++axis) {
      if (std::abs(f[axis]) > 1e-6) {
        ++normal_axes;
        EXPECT_NEAR(std::abs(f[axis]), 0.1, 1e-4);
        EXPECT_GT(f[axis] * start[axis], 0);  // outward
      }
    }
    EXPECT_EQ(normal_axes, 1) << start.transpose();
  }
  // From inside (a room): concave edges hold two constraints, concave corners three, and the
  // proxy sits exactly on the feature.
  const Vec3 pushes[] = {Vec3(1.2, 0.1, 0.2), Vec3(1.2, 1.2, 0.3), Vec3(1.2, -1.2, 1.2)};
  for (const Vec3& goal : pushes) {
    GodObject god;
    god.reset(Vec3(0.1, 0.05, 0.02));
    ContactResult c;
    for (int k = 0; k <= 100; ++k) c = god.update(set, goal * (k / 100.0));
    const int expected = int((goal.cwiseAbs().array() > 1).count());
    EXPECT_EQ(c.constraints, expected) << goal.transpose();
    for (int axis = 0; axis < 3; ++axis) {
      if (std::abs(goal[axis]) > 1) {
        EXPECT_NEAR(std::abs(c.proxy[axis]), 1, 1e-4);
        EXPECT_LT(std::abs(c.proxy[axis]), 1);  // still inside the room
      } else {
        EXPECT_NEAR(c.proxy[axis], goal[axis], 1e-6);
      }
    }
  }
  // A random walk of the goal through the cube: the proxy is never inside.
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-0.05, 0.05);
  GodObject god;
  god.reset(Vec3(2, 2, 2));
  Vec3 goal(2, 2, 2);
  for (int k = 0; k < 20000; ++k) {
    goal += Vec3(u(rng), u(rng), u(rng)) - 0.002 * goal;
    const ContactResult c = god.update(set, goal);
    ASSERT_FALSE(inside_cube(c.proxy, 1e-6)) << "step " << k;
  }
}

TEST(Contact, ThinPlateIsTouchableFromBothSides) {
  const TriangleSet set = index(plate(4));
  for (const double side : {1.0, -1.0}) {
    GodObject god;
    god.reset(Vec3(2.3, 1.7, 0.5 * side));
    ContactResult c;
    for (int k = 0; k <= 100; ++k) {
      c = god.update(set, Vec3(2.3 + 0.01 * k, 1.7, (0.5 - 1.5 * k / 100.0) * side));
      ASSERT_GE(c.proxy.z() * side, 0) << "went through the plate";
    }
    EXPECT_TRUE(c.in_contact);
    EXPECT_NEAR(c.normal.z(), side, 1e-9);
    EXPECT_NEAR(c.proxy.x(), 3.3, 1e-6);  // slides freely along the plate
    // Fast: one step far through the plate is still stopped (no tunnelling).
    GodObject fast;
    fast.reset(Vec3(1.1, 1.1, 0.2 * side));
    c = fast.update(set, Vec3(1.1, 1.1, -50 * side));
    EXPECT_GE(c.proxy.z() * side, 0);
  }
}

TEST(Contact, TheProxyFallsThroughAHoleButNotBesideIt) {
  const TriangleSet set =
      index(plate(6, Eigen::AlignedBox2d(Eigen::Vector2d(2, 2), Eigen::Vector2d(4, 4))));
  GodObject through;
  through.reset(Vec3(3, 3, 1));
  ContactResult c = through.update(set, Vec3(3, 3, -1));
  EXPECT_FALSE(c.in_contact);
  EXPECT_NEAR(c.proxy.z(), -1, 1e-12);
  GodObject beside;
  beside.reset(Vec3(1, 1, 1));
  c = beside.update(set, Vec3(1, 1, -1));
  EXPECT_TRUE(c.in_contact);
  EXPECT_GE(c.proxy.z(), 0);
  // Sliding on the plate toward the hole: the proxy drops in once past the rim.
  GodObject slide;
  slide.reset(Vec3(0.5, 3, 0.5));
  for (int k = 0; k <= 100; ++k) c = slide.update(set, Vec3(0.5 + 0.025 * k, 3, -0.2));
  EXPECT_FALSE(c.in_contact);
  EXPECT_NEAR(c.proxy.z(), -0.2, 1e-9);
}

TEST(Contact, FrictionHoldsInsideTheConeAndSlidesOutside) {
  const TriangleSet set = index(plate(4));
  ContactOptions o;
  o.friction = 0.5;
  GodObject god(o);
  god.reset(Vec3(2, 2, 0.1));
  god.update(set, Vec3(2, 2, -0.2));
  ContactResult c = god.update(set, Vec3(2.05, 2, -0.2));  // pull 0.05 < 0.5 x 0.2
  EXPECT_NEAR(c.proxy.x(), 2, 1e-9);
  c = god.update(set, Vec3(2.5, 2, -0.2));  // 0.5 > 0.1: slides
  EXPECT_NEAR(c.proxy.x(), 2.5, 1e-9);
}

TEST(TriangleSet, QueriesAgreeWithBruteForce) {
  const SurfaceMesh mesh = sphere(1.0, 32, 16);
  const TriangleSet set = index(mesh);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.5, 1.5);
  for (int i = 0; i < 300; ++i) {
    const Vec3 p(u(rng), u(rng), u(rng));
    ClosestHit hit;
    ASSERT_TRUE(set.closest(p, 10, hit));
    double best = 1e9;
    for (std::uint32_t t = 0; t < set.size(); ++t) {
      const auto& c = set.corners(t);
      best = std::min(best, (closest_on_triangle(p, c[0], c[1], c[2]) - p).norm());
    }
    EXPECT_NEAR(hit.distance, best, 1e-12);
    const Vec3 q(u(rng), u(rng), u(rng));
    SegmentHit s;
    const bool any = set.first_hit(p, q, s);
    const bool crosses = (p.norm() < 0.99) != (q.norm() < 0.99);
    if (crosses) {
      EXPECT_TRUE(any);
    }
  }
  std::vector<std::uint32_t> near;
  set.in_sphere(Vec3(1, 0, 0), 0.3, near);
  EXPECT_GT(near.size(), 0u);
  EXPECT_LT(near.size(), set.size() / 4);
}

// ---- the loop ----

struct LoopRig {
  device::SimulatedDevice sim;
  device::SafetyFilter safe;
  ProxyPatchExchange patches;
  HapticLoop loop;
  static device::SimulatedOptions options(bool virtual_clock) {
    device::SimulatedOptions o;
    o.virtual_clock = virtual_clock;
    o.start = Vec3(0, 0, 0.02);
    return o;
  }
  static HapticLoopOptions loop_options() {
    HapticLoopOptions o;
    o.stiffness = 800;
    o.workspace.scale = 1.0;  // device metres = model units
    return o;
  }
  explicit LoopRig(bool virtual_clock)
      : sim(options(virtual_clock)), safe(sim), loop(safe, patches, loop_options()) {}
  void publish_plate(double z, std::uint64_t version) {
    SurfaceMesh m = plate(4);
    for (auto& p : m.positions) p = Vec3(p.x() * 0.05 - 0.1, p.y() * 0.05 - 0.1, z);
    ProxyPatch& patch = patches.back();
    patch.version = version;
    patch.centre = Vec3(0, 0, z);
    patch.radius = 1;
    patch.triangles.build(m);
    patches.publish();
  }
};

TEST(HapticLoop, PushesBackOutOfAPlateAndEasesInARemoteEdit) {
  LoopRig rig(true);
  ASSERT_TRUE(rig.safe.open().ok);
  rig.publish_plate(0.0, 1);
  rig.safe.arm();
  // The hand pushes 1 cm into the plate.
  rig.sim.set_target(Vec3(0, 0, -0.01), 0);
  std::int64_t now = 0;
  for (int i = 0; i < 3000; ++i) {
    rig.sim.advance(1'000'000);
    now += 1'000'000;
    rig.loop.step(now);
  }
  auto& ui = rig.loop.ui_state();
  ui.update();
  ToolState s = ui.front();
  EXPECT_TRUE(s.in_contact);
  EXPECT_GT(s.force.z(), 0.5);  // pushing up, along the plate's normal
  EXPECT_LT(std::abs(s.force.x()) + std::abs(s.force.y()), 1e-3);
  EXPECT_GE(s.proxy.z(), 0);
  // A remote edit lifts the surface by 2 mm, above the proxy: the proxy is re-seated on the
  // new surface (not left behind it), and the force eases in instead of jumping by
  // k x 2 mm = 1.6 N in one tick.
  const double before = s.force.z();
  rig.publish_plate(0.002, 2);
  double previous = before;
  double largest_step = 0;
  for (int i = 0; i < 30; ++i) {
    rig.sim.advance(1'000'000);
    now += 1'000'000;
    rig.loop.step(now);
    ui.update();
    largest_step = std::max(largest_step, std::abs(ui.front().force.z() - previous));
    previous = ui.front().force.z();
  }
  EXPECT_GE(ui.front().proxy.z(), 0.002);
  EXPECT_TRUE(ui.front().in_contact);
  EXPECT_GT(previous, before);
  EXPECT_LT(largest_step, 0.8 * 1.6 / 5);
}

TEST(HapticLoop, PlaneConstraintHoldsTheToolToThePlane) {
  LoopRig rig(true);
  ASSERT_TRUE(rig.safe.open().ok);
  rig.publish_plate(0.0, 1);
  rig.safe.arm();
  std::int64_t now = 0;
  const auto run = [&](int ticks) {
    for (int i = 0; i < ticks; ++i) {
      rig.sim.advance(1'000'000);
      now += 1'000'000;
      rig.loop.step(now);
    }
    auto& ui = rig.loop.ui_state();
    ui.update();
    return ui.front();
  };
  run(200);  // armed in free space first, as at the station (the fixture comes with a sweep)
  // The hand pushes into the plate 1 cm to the side of the plane x = 0.
  PlaneConstraint plane;
  plane.active = true;
  plane.point = Vec3(0, 0, 0);
  plane.normal = Vec3(1, 0, 0);
  rig.loop.set_constraint(plane);
  rig.sim.set_target(Vec3(0.01, 0, -0.005), 0);
  ToolState s = run(3000);
  EXPECT_TRUE(s.in_contact);
  EXPECT_NEAR(s.proxy.x(), 0.0, 1e-9);  // the proxy stays on the plane
  EXPECT_LT(s.force.x(), -0.5);         // and the device is pulled back toward it
  EXPECT_GT(s.force.z(), 0.5);          // while the plate still pushes up
  // Released: the proxy follows the hand off the plane again.
  plane.active = false;
  rig.loop.set_constraint(plane);
  s = run(3000);
  EXPECT_GT(s.proxy.x(), 0.005);
  EXPECT_LT(std::abs(s.force.x()), 0.05);
}

TEST(HapticLoop, RealThreadRunsWithoutAllocatingAndKeepsItsRate) {
  LoopRig rig(false);
  ASSERT_TRUE(rig.safe.open().ok);
  rig.publish_plate(0.0, 1);
  rig.safe.arm();
  rig.sim.set_target(Vec3(0, 0, -0.005), 1);
  ProxyUpdater updater(rig.loop, rig.patches);
  auto mesh = std::make_shared<SurfaceMesh>(sphere(0.03, 64, 32));
  mesh->version = 3;
  g_haptic_allocations = 0;
  rig.loop.start();
  updater.set_surface(mesh);
  updater.start();
  std::this_thread::sleep_for(std::chrono::milliseconds(400));
  updater.stop();
  rig.loop.stop();
  const LoopStats stats = rig.loop.stats();
  EXPECT_GT(stats.ticks, 300u);  // ~1 kHz for 0.4 s (loose: this is a test, not a benchmark)
  EXPECT_GT(stats.patches_taken, 1u);
  EXPECT_GT(updater.patches_built(), 0u);
  EXPECT_EQ(g_haptic_allocations.load(), 0u) << "the haptic thread allocated";
  EXPECT_GT(rig.loop.period_error().count(), 100u);
  ToolSampleOut sample;
  EXPECT_TRUE(rig.loop.samples().pop(sample));
}

}  // namespace
}  // namespace touchmend::haptics
