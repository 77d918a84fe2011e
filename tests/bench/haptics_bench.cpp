// touchmend-haptics-bench: the haptic targets of DESIGN.md, as distributions.
//   1. contact query (one god-object update: sweep, constraints, projection) while sliding
//      pressed into a bumpy sphere: on a ~20k-triangle local patch (target p99 <= 5 us) and on
//      the whole 1M-triangle mesh (target p99 <= 20 us);
//   2. haptic loop period error at 1 kHz and 4 kHz while the viewer renders (when a display
//      is available: run under xvfb-run) and new meshes ("deltas") keep arriving: p50, p99,
//      p99.9, max (targets at 1 kHz: p99 <= 100 us, p99.9 <= 200 us), with and without
//      SCHED_FIFO, and the allocations made on the haptic thread (target 0).

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <iostream>
#include <new>
#include <numbers>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "client/haptics/haptic_loop.h"
#include "client/haptics/proxy_updater.h"
#include "client/view/viewer.h"
#include "device/simulated_device.h"
#include "tests/support/allocation_probe.h"
#include "tests/support/haptic_meshes.h"

using namespace touchmend;
using haptics::Vec3;
using Clock = std::chrono::steady_clock;

namespace {

haptics::SurfaceMesh bumpy_sphere(double r, int around, int rings) {
  return testing::uv_sphere_surface(r, around, rings, 0.02);
}

std::string distribution(std::vector<double> v, const char* unit) {
  std::sort(v.begin(), v.end());
  auto at = [&](double q) {
    return v[std::min(v.size() - 1, std::size_t(q * double(v.size() - 1) + 0.5))];
  };
  return fmt::format("n={} p50={:.2f} p99={:.2f} p99.9={:.2f} max={:.2f} {}", v.size(), at(0.5),
                     at(0.99), at(0.999), v.back(), unit);
}

//! Slides the goal along a great circle pressed 0.3 mm into the surface (device-scale
//! motion: ~0.1 mm per tick), timing every god-object update.
//! \p swing: 0 for a path along the great circle; else the angle swings back and forth by
//! this much (to stay inside a local patch).
std::vector<double> time_contact(const haptics::TriangleSet& set, int steps, double radius,
                                 std::uint64_t& tests, double swing = 0) {
  haptics::GodObject god;
  const Vec3 axis = Vec3(0.3, 1, 0.2).normalized();
  const Vec3 start = Vec3(1, 0, 0).cross(axis).normalized();
  god.reset(1.5 * radius * start);
  std::vector<double> us;
  us.reserve(std::size_t(steps));
  tests = 0;
  for (int k = 0; k < steps; ++k) {
    // 0.05 mm per tick on a 0.1 m sphere (a brisk 50 mm/s stroke).
    const double angle = swing > 0 ? swing * std::sin(0.0005 * k / swing) : 0.0005 * k;
    const Vec3 dir = (start * std::cos(angle) + axis.cross(start) * std::sin(angle)).normalized();
    const double depth = k < 50 ? 1.5 - 0.55 * k / 50.0 : 0.97;  // approach, then pressed in
    const Vec3 goal = depth * radius * dir;
    const auto t0 = Clock::now();
    const haptics::ContactResult c = god.update(set, goal);
    const auto t1 = Clock::now();
    tests += set.last_tests;
    if (k >= 60) us.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
    if (k >= 60 && !c.in_contact) std::cerr << "lost contact at step " << k << "\n";
  }
  return us;
}

void contact_bench(int steps) {
  const double r = 0.1;
  std::cout << "building a 1M-triangle bumpy sphere...\n";
  const haptics::SurfaceMesh mesh = bumpy_sphere(r, 1000, 501);
  haptics::TriangleSet whole;
  auto t0 = Clock::now();
  whole.build(mesh);
  const double build_s = std::chrono::duration<double>(Clock::now() - t0).count();
  std::cout << fmt::format("whole mesh: {} triangles, BVH build {:.2f} s\n", whole.size(), build_s);
  std::uint64_t tests = 0;
  const auto whole_us = time_contact(whole, steps, r, tests);
  std::cout << fmt::format(
      "contact query, whole 1M-triangle mesh: {} (triangle tests/query {:.1f})\n",
      distribution(whole_us, "us"), double(tests) / steps);
  // A local patch of ~20k triangles around the path's start (what the proxy-update thread cuts).
  const Vec3 axis = Vec3(0.3, 1, 0.2).normalized();
  const Vec3 start = Vec3(1, 0, 0).cross(axis).normalized() * r;
  std::vector<std::uint32_t> near;
  double radius = 0.01;
  for (int i = 0; i < 40; ++i) {
    whole.in_sphere(start, radius, near);
    if (near.size() >= 20000) break;
    radius *= 1.1;
  }
  haptics::TriangleSet patch;
  t0 = Clock::now();
  patch.build_from(whole, near);
  const double patch_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  // Strokes back and forth inside the patch.
  const int patch_steps = steps;
  const auto patch_us = time_contact(patch, patch_steps, r, tests, 0.7 * radius / r);
  std::cout << fmt::format(
      "contact query, local patch of {} triangles (radius {:.1f} mm, build {:.1f} ms): {} "
      "(triangle tests/query {:.1f})\n",
      patch.size(), radius * 1000, patch_ms, distribution(patch_us, "us"),
      double(tests) / patch_steps);
}

void loop_bench(double rate, double seconds, bool realtime, bool with_viewer, double spin_us) {
  device::SimulatedOptions so;
  device::SimulatedDevice sim(so);
  device::SafetyFilter safe(sim);
  safe.open();
  haptics::ProxyPatchExchange patches;
  haptics::HapticLoopOptions lo;
  lo.rate_hz = rate;
  lo.realtime = realtime;
  lo.spin_ns = static_cast<std::int64_t>(spin_us * 1000);
  lo.workspace.scale = 1.0;
  haptics::HapticLoop loop(safe, patches, lo);
  haptics::ProxyUpdater updater(loop, patches);
  auto mesh =
      std::make_shared<haptics::SurfaceMesh>(bumpy_sphere(0.05, 400, 201));  // 160k triangles
  mesh->version = 1;
  updater.set_surface(mesh);
  updater.start();
  sim.set_target(Vec3(0.03, 0.0, 0.035), 0);  // pressed into the sphere's side
  loop.start();
  safe.arm();
  std::unique_ptr<view::Viewer> viewer;
  std::string error;
  if (with_viewer) {
    view::ViewerOptions vo;
    vo.visible = true;
    viewer = std::make_unique<view::Viewer>(vo);
    if (!viewer->open(error)) viewer.reset();
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(500));  // settle, arm, first patches
  loop.reset_statistics();
  g_haptic_allocations = 0;
  const auto start = Clock::now();
  std::uint64_t version = 1;
  auto last_delta = start;
  int frames = 0;
  const double sweep = 2 * std::numbers::pi / 4.0;  // the hand circles once every 4 s
  while (Clock::now() - start < std::chrono::duration<double>(seconds)) {
    const double t = std::chrono::duration<double>(Clock::now() - start).count();
    sim.set_target(Vec3(0.035 * std::cos(sweep * t), 0.035 * std::sin(sweep * t), 0.03), 0);
    if (Clock::now() - last_delta > std::chrono::milliseconds(200)) {
      // A "delta": the mesh changes (a new version), so a new index and patch are built.
      auto next = std::make_shared<haptics::SurfaceMesh>(*mesh);
      next->version = ++version;
      updater.set_surface(next);
      last_delta = Clock::now();
    }
    if (viewer) {
      view::Scene scene;
      scene.surface = mesh;
      auto& ui = loop.ui_state();
      ui.update();
      scene.cursors.push_back({ui.front().proxy, {0.3f, 0.8f, 1.0f}, 14});
      viewer->draw(scene);
      ++frames;
    } else {
      std::this_thread::sleep_for(std::chrono::milliseconds(16));
    }
  }
  loop.stop();
  updater.stop();
  safe.close();
  const auto& h = loop.period_error();
  const auto stats = loop.stats();
  std::cout << fmt::format(
      "loop {:.0f} Hz, spin {:.0f} us, {:.0f} s, {}{}: period error p50={:.0f} p99={:.0f} "
      "p99.9={:.0f} max={:.0f} us | compute p99={:.0f} us | "
      "{} ticks, {} overruns, {} patches, {} viewer frames, haptic-thread allocations: {} | {}\n",
      rate, spin_us, seconds, realtime ? "SCHED_FIFO requested" : "normal scheduling",
      viewer ? ", viewer drawing"
             : (with_viewer ? ", no display: viewer skipped (" + error + ")" : ""),
      h.percentile_us(0.5), h.percentile_us(0.99), h.percentile_us(0.999), h.max_us(),
      loop.compute_time().percentile_us(0.99), stats.ticks, stats.overruns, stats.patches_taken,
      frames, g_haptic_allocations.load(), stats.realtime_note);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"touchmend-haptics-bench: contact-query and haptic-loop timing distributions"};
  int steps = 20000;
  double seconds = 10;
  bool skip_contact = false, skip_loop = false, no_viewer = false;
  double spin_us = 80;
  std::vector<double> rates{1000, 4000};
  app.add_option("--steps", steps, "Contact queries per run")->capture_default_str();
  app.add_option("--seconds", seconds, "Duration of each loop run")->capture_default_str();
  app.add_flag("--skip-contact", skip_contact, "Only the loop runs");
  app.add_flag("--skip-loop", skip_loop, "Only the contact queries");
  app.add_flag("--no-viewer", no_viewer, "Do not render while the loop runs");
  app.add_option("--spin-us", spin_us, "Busy-wait before each deadline (the loop's spin_ns)")
      ->capture_default_str();
  app.add_option("--rates", rates, "Loop rates to run")->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  std::cout << fmt::format("machine: {} cores\n", std::thread::hardware_concurrency());
  if (!skip_contact) contact_bench(steps);
  if (!skip_loop) {
    for (const bool rt : {false, true})
      for (const double rate : rates) loop_bench(rate, seconds, rt, !no_viewer, spin_us);
  }
  return 0;
}
