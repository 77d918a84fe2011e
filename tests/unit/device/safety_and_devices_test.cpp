// The safety filter on the simulated device (virtual clock: deterministic, faster than real
// time), the simulated stylus's physics, and trajectories (format, replay, recording).

#include <filesystem>
#include <fstream>
#include <random>

#include <gtest/gtest.h>

#include "device/device_factory.h"
#include "device/safety_filter.h"
#include "device/simulated_device.h"
#include "device/trajectory.h"
#include "device/triple_buffer.h"

namespace touchmend::device {
namespace {

constexpr std::int64_t kTick = 1'000'000;  // 1 ms

struct Rig {
  SimulatedDevice sim;
  SafetyFilter safe;
  explicit Rig(SimulatedOptions o = virtual_options(), SafetyOptions s = {})
      : sim(std::move(o)), safe(sim, s) {}
  static SimulatedOptions virtual_options() {
    SimulatedOptions o;
    o.virtual_clock = true;
    return o;
  }
  //! One haptic tick: read, then write the request.
  void tick(const Eigen::Vector3d& request) {
    sim.advance(kTick);
    DeviceState s;
    safe.read(s);
    safe.write({request, 0});
  }
};

TEST(SafetyFilter, ZeroUntilArmedThenGateRampClampAndSlew) {
  Rig rig;
  ASSERT_TRUE(rig.safe.open().ok);
  const Eigen::Vector3d push(0, 0, 3.0);
  for (int i = 0; i < 50; ++i) {
    rig.tick(push);
    EXPECT_TRUE(rig.safe.last_output().isZero()) << "disarmed must be zero";
  }
  rig.safe.arm();
  // A large request blocks the arming gate (needs < 0.2 N for 3 ticks).
  for (int i = 0; i < 20; ++i) rig.tick(push);
  EXPECT_EQ(rig.safe.arm_state(), ArmState::WaitingForSmallForce);
  EXPECT_TRUE(rig.safe.last_output().isZero());
  for (int i = 0; i < 3; ++i) rig.tick(Eigen::Vector3d(0, 0, 0.05));
  EXPECT_EQ(rig.safe.arm_state(), ArmState::Ramping);
  // Ramping in, then armed: the output follows the request but never jumps by more than
  // cap/10 per tick, and never exceeds the cap.
  Eigen::Vector3d previous = rig.safe.last_output();
  const double cap = rig.safe.force_cap();
  for (int i = 0; i < 1200; ++i) {
    rig.tick(Eigen::Vector3d(0, 0, 100.0));  // far above the cap
    const Eigen::Vector3d out = rig.safe.last_output();
    EXPECT_LE((out - previous).norm(), cap / 10 + 1e-9);
    EXPECT_LE(out.norm(), cap + 1e-9);
    EXPECT_GE(out.z(), 0);  // direction kept
    EXPECT_NEAR(out.x(), 0, 1e-12);
    previous = out;
  }
  EXPECT_EQ(rig.safe.arm_state(), ArmState::Armed);
  EXPECT_NEAR(rig.safe.last_output().norm(), cap, 1e-9);
  EXPECT_GT(rig.safe.counters().clamped, 0u);
  // A step down to zero while armed is spread over ten ticks.
  rig.tick(Eigen::Vector3d::Zero());
  EXPECT_NEAR(rig.safe.last_output().norm(), 0.9 * cap, 1e-9);
  EXPECT_GT(rig.safe.counters().slew_limited, 0u);
  // Disarm cuts to zero on the very next write (no slew on the way down).
  rig.safe.disarm();
  rig.tick(Eigen::Vector3d(0, 0, 1.0));
  EXPECT_TRUE(rig.safe.last_output().isZero());
}

void arm_fully(Rig& rig) {
  rig.safe.arm();
  for (int i = 0; i < 5; ++i) rig.tick(Eigen::Vector3d::Zero());
  for (int i = 0; i < 1100; ++i) rig.tick(Eigen::Vector3d(0, 0, 0.5));
  ASSERT_EQ(rig.safe.arm_state(), ArmState::Armed);
}

TEST(SafetyFilter, NanStaleHomingLossAndFaultsGiveZeroAtOnce) {
  Rig rig;
  ASSERT_TRUE(rig.safe.open().ok);
  arm_fully(rig);
  EXPECT_FALSE(rig.safe.last_output().isZero());
  // NaN: zero that tick, forces resume after.
  rig.tick(Eigen::Vector3d(NAN, 0, 0));
  EXPECT_TRUE(rig.safe.last_output().isZero());
  EXPECT_EQ(rig.safe.counters().non_finite, 1u);
  rig.tick(Eigen::Vector3d(0, 0, 0.5));
  EXPECT_FALSE(rig.safe.last_output().isZero());
  // Too many NaNs in a row: a fault, zero until cleared and re-armed.
  for (int i = 0; i < 10; ++i) rig.tick(Eigen::Vector3d(0, INFINITY, 0));
  EXPECT_EQ(rig.safe.arm_state(), ArmState::Faulted);
  rig.tick(Eigen::Vector3d(0, 0, 0.5));
  EXPECT_TRUE(rig.safe.last_output().isZero());
  rig.safe.clear_error();
  arm_fully(rig);
  // Stale state (the device stopped updating): zero.
  rig.sim.inject_stall(true);
  for (int i = 0; i < 3; ++i) rig.tick(Eigen::Vector3d(0, 0, 0.5));
  EXPECT_TRUE(rig.safe.last_output().isZero());
  EXPECT_GT(rig.safe.counters().stale, 0u);
  rig.sim.inject_stall(false);
  rig.tick(Eigen::Vector3d(0, 0, 0.5));
  EXPECT_FALSE(rig.safe.last_output().isZero());
  // Homing loss: zero and disarmed.
  rig.sim.inject_unhome();
  rig.tick(Eigen::Vector3d(0, 0, 0.5));
  EXPECT_TRUE(rig.safe.last_output().isZero());
  EXPECT_EQ(rig.safe.arm_state(), ArmState::Disarmed);
  EXPECT_EQ(rig.safe.counters().homing_losses, 1u);
  // Re-arming needs homing first.
  rig.safe.arm();
  for (int i = 0; i < 10; ++i) rig.tick(Eigen::Vector3d::Zero());
  EXPECT_EQ(rig.safe.arm_state(), ArmState::WaitingForSmallForce);
  rig.sim.home();
  for (int i = 0; i < 5; ++i) rig.tick(Eigen::Vector3d::Zero());
  EXPECT_EQ(rig.safe.arm_state(), ArmState::Ramping);
  // A device fault: zero.
  rig.sim.inject_fault();
  rig.tick(Eigen::Vector3d(0, 0, 0.5));
  EXPECT_EQ(rig.safe.arm_state(), ArmState::Faulted);
  EXPECT_TRUE(rig.safe.last_output().isZero());
}

TEST(SafetyFilter, WatchdogDropsToZeroWhenTheLoopStalls) {
  Rig rig;
  ASSERT_TRUE(rig.safe.open().ok);
  arm_fully(rig);
  rig.sim.advance(kTick);
  DeviceState s;
  rig.sim.read(s);
  EXPECT_FALSE(rig.sim.applied_force().isZero());
  // The loop stops writing: within the watchdog time the device applies zero by itself.
  rig.sim.advance(5 * kTick);
  rig.sim.read(s);
  EXPECT_TRUE(rig.sim.applied_force().isZero());
}

TEST(SafetyFilter, VelocityLimitAndGainAdmission) {
  SafetyOptions options;
  options.velocity_limit = 0.3;
  SimulatedOptions sim = Rig::virtual_options();
  sim.script = {{0, Eigen::Vector3d::Zero(), 0},
                {1.1, Eigen::Vector3d::Zero(), 0},
                {1.25, Eigen::Vector3d(0.09, 0, 0), 0}};  // a fast jerk after arming
  Rig rig(sim, options);
  ASSERT_TRUE(rig.safe.open().ok);
  arm_fully(rig);
  bool cut = false;
  for (int i = 0; i < 200; ++i) {
    rig.tick(Eigen::Vector3d(0, 0, 0.5));
    if (rig.safe.counters().velocity_trips > 0 && !cut) {
      cut = true;
      EXPECT_TRUE(rig.safe.last_output().isZero());  // zero on the tick of the trip
    }
  }
  EXPECT_TRUE(cut);
  // A force-type fault: once the stylus is slow again it re-arms by itself (gate, ramp).
  for (int i = 0; i < 1500; ++i) rig.tick(Eigen::Vector3d::Zero());
  EXPECT_EQ(rig.safe.arm_state(), ArmState::Armed);
  const Gains g = admit_gains(rig.sim.info(), 1e6, -3);
  EXPECT_TRUE(g.capped);
  EXPECT_EQ(g.stiffness, rig.sim.info().max_stiffness);
  EXPECT_EQ(g.damping, 0);
}

TEST(SimulatedDevice, HandPullsTheStylusToTheTargetAndForcesPushBack) {
  SimulatedOptions o = Rig::virtual_options();
  o.script = {{0, Eigen::Vector3d::Zero(), 0}, {0.5, Eigen::Vector3d(0.02, 0, 0), 1}};
  SimulatedDevice sim(o);
  ASSERT_TRUE(sim.open().ok);
  DeviceState s;
  for (int i = 0; i < 1500; ++i) {
    sim.advance(kTick);
    sim.read(s);
  }
  EXPECT_NEAR(s.position.x(), 0.02, 1e-3);
  EXPECT_EQ(s.buttons, 1u);  // past the last waypoint: its buttons
  // A constant commanded force displaces the equilibrium by F / k_hand.
  for (int i = 0; i < 1500; ++i) {
    sim.write({Eigen::Vector3d(0, 0, 1.5), sim.now_ns() + 3 * kTick});
    sim.advance(kTick);
    sim.read(s);
  }
  EXPECT_NEAR(s.position.z(), 1.5 / o.hand_stiffness, 1e-3);
}

TEST(Trajectory, FormatRoundTripAndClearErrors) {
  Trajectory trajectory;
  trajectory.workspace =
      Eigen::AlignedBox3d(Eigen::Vector3d::Constant(-0.1), Eigen::Vector3d::Constant(0.1));
  std::vector<TrajectorySample>& samples = trajectory.samples;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-0.05, 0.05);
  for (int i = 0; i < 500; ++i)
    samples.push_back({i * 0.001, Eigen::Vector3d(u(rng), u(rng), u(rng)), std::uint32_t(i % 3)});
  Trajectory back;
  ASSERT_TRUE(parse_trajectory(format_trajectory(trajectory), back).ok);
  ASSERT_EQ(back.samples.size(), samples.size());
  EXPECT_TRUE(back.workspace.isApprox(trajectory.workspace));
  for (std::size_t i = 0; i < samples.size(); ++i) {
    EXPECT_EQ(back.samples[i].position, samples[i].position);  // exact: shortest round-trip
    EXPECT_EQ(back.samples[i].buttons, samples[i].buttons);
  }
  auto error = [](const std::string& text) {
    Trajectory out;
    const DeviceStatus s = parse_trajectory(text, out);
    EXPECT_FALSE(s.ok) << text;
    return s.message;
  };
  EXPECT_NE(error("").find("no header"), std::string::npos);
  EXPECT_NE(error("touchmend-trajectory 2\n0 0 0 0 0\n").find("version 2"), std::string::npos);
  EXPECT_NE(error("hello\n").find("not a touchmend trajectory"), std::string::npos);
  EXPECT_NE(error("touchmend-trajectory 1\n0 0 nan 0 0\n").find("line 2"), std::string::npos);
  EXPECT_NE(error("touchmend-trajectory 1\n1 0 0 0 0\n0.5 0 0 0 0\n").find("backwards"),
            std::string::npos);
  EXPECT_NE(error("touchmend-trajectory 1\n0 0 0 0\n").find("expected"), std::string::npos);
  EXPECT_NE(error("touchmend-trajectory 1\n0 0 0 0 -1\n").find("buttons"), std::string::npos);
  EXPECT_NE(error("touchmend-trajectory 1\n# only a comment\n").find("no samples"),
            std::string::npos);
  EXPECT_NE(error("touchmend-trajectory 1\n0 0 0 0 0\nworkspace 0 0 0 1 1 1\n").find("before"),
            std::string::npos);
  EXPECT_NE(error("touchmend-trajectory 1\nworkspace 0 0 0 1 1\n").find("workspace"),
            std::string::npos);
}

TEST(Trajectory, RandomTextIsRejectedCleanly) {
  std::mt19937 rng(23);
  std::uniform_int_distribution<int> byte(0, 255), length(0, 400);
  const std::string alphabet = "touchmend-trajectory 1\nworkspace0123456789.-+eE #\t\r nan inf";
  std::uniform_int_distribution<std::size_t> pick(0, alphabet.size() - 1);
  int accepted = 0;
  for (int i = 0; i < 3000; ++i) {
    std::string text = i % 2 ? "touchmend-trajectory 1\n" : "";
    const int n = length(rng);
    for (int k = 0; k < n; ++k) text += i % 3 ? alphabet[pick(rng)] : static_cast<char>(byte(rng));
    Trajectory out;
    const DeviceStatus s = parse_trajectory(text, out);
    if (s.ok) {
      ++accepted;
      ASSERT_FALSE(out.samples.empty());
      for (std::size_t j = 0; j < out.samples.size(); ++j) {
        ASSERT_TRUE(out.samples[j].position.allFinite());
        if (j > 0) {
          ASSERT_GE(out.samples[j].t, out.samples[j - 1].t);
        }
      }
    } else {
      EXPECT_FALSE(s.message.empty());
    }
  }
  EXPECT_LT(accepted, 3000);
}

TEST(Trajectory, RecordThenReplayReproducesTheMotion) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("touchmend-traj-" + std::to_string(std::random_device{}()));
  std::filesystem::create_directories(dir);
  const auto file = dir / "rec.traj";
  SimulatedOptions o = Rig::virtual_options();
  o.script = {{0, Eigen::Vector3d::Zero(), 0}, {0.2, Eigen::Vector3d(0.01, 0.02, -0.01), 1}};
  SimulatedDevice sim(o);
  DeviceState recorded_last;
  {
    RecordingDevice rec(sim, file, 1000);
    ASSERT_TRUE(rec.open().ok);
    DeviceState s;
    for (int i = 0; i < 300; ++i) {
      sim.advance(kTick);
      rec.read(s);
    }
    EXPECT_EQ(rec.recorded(), 300u);
    recorded_last = s;
    rec.close();
  }
  std::unique_ptr<ReplayDevice> replay;
  ReplayOptions ro;
  ro.virtual_clock = true;
  ASSERT_TRUE(ReplayDevice::from_file(file, ro, replay).ok);
  ASSERT_TRUE(replay->open().ok);
  EXPECT_NEAR(replay->duration_seconds(), 0.299, 1e-9);
  EXPECT_TRUE(replay->info().workspace.isApprox(sim.info().workspace));  // kept in the file
  DeviceState s;
  replay->advance(250 * kTick);
  ASSERT_TRUE(replay->read(s));
  EXPECT_EQ(s.buttons, 1u);
  replay->advance(100 * kTick);
  replay->read(s);
  EXPECT_TRUE(replay->finished());
  EXPECT_EQ(s.position, recorded_last.position);  // exact: the file keeps every digit
  replay->write({Eigen::Vector3d(1, 0, 0), 0});
  EXPECT_EQ(replay->commands_written(), 1u);
  std::filesystem::remove_all(dir);
  std::unique_ptr<ReplayDevice> missing;
  EXPECT_FALSE(ReplayDevice::from_file(dir / "nope.traj", ro, missing).ok);
}

TEST(DeviceFactory, SpecsAndListing) {
  DeviceSpec spec;
  EXPECT_TRUE(parse_device_spec("sim", spec).ok);
  EXPECT_EQ(spec.kind, DeviceSpec::Kind::Simulated);
  EXPECT_TRUE(parse_device_spec("replay:/tmp/a.traj", spec).ok);
  EXPECT_EQ(spec.file, "/tmp/a.traj");
  EXPECT_TRUE(parse_device_spec("falcon:2", spec).ok);
  EXPECT_EQ(spec.index, 2);
  EXPECT_FALSE(parse_device_spec("falcon:x", spec).ok);
  EXPECT_FALSE(parse_device_spec("replay:", spec).ok);
  EXPECT_FALSE(parse_device_spec("phantom", spec).ok);
  std::string notes;
  const auto list = list_devices(notes);
  ASSERT_GE(list.size(), 2u);
  EXPECT_EQ(list[0].spec, "sim");
}

TEST(TripleBuffer, ConsumerAlwaysSeesAWholeNewestValue) {
  struct Pair {
    std::uint64_t a = 0, b = 0;
  };
  TripleBuffer<Pair> buffer(Pair{0, ~std::uint64_t{0}});
  std::atomic<bool> done{false};
  std::thread producer([&] {
    for (std::uint64_t i = 1; i <= 200000; ++i) {
      buffer.back() = {i, ~i};
      buffer.publish();
    }
    done = true;
  });
  std::uint64_t last = 0;
  while (!done || buffer.update()) {
    buffer.update();
    const Pair& p = buffer.front();
    ASSERT_EQ(p.b, ~p.a);  // never torn
    ASSERT_GE(p.a, last);  // never goes back in time
    last = p.a;
  }
  producer.join();
  buffer.update();
  EXPECT_EQ(buffer.front().a, 200000u);
}

}  // namespace
}  // namespace touchmend::device
