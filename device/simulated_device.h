#pragma once

//! \file simulated_device.h
//! \brief A virtual stylus: a point mass with device damping, pulled by a "hand" (a
//! spring-damper toward a target) and pushed by the commanded force (HAPTICS.md §5.2).
//!
//! \details The target comes from a script (waypoints interpolated in time) or from
//! set_target() (mouse and keyboard in the viewer). Physics advances in fixed sub-steps up to
//! the device clock whenever the state is read: on the steady clock (real time), or on a
//! virtual clock that tests advance by hand, so a test of a second of motion runs in
//! microseconds and is deterministic. Fault injection: stalls (the state stops updating),
//! homing loss, a device fault.

#include <atomic>
#include <vector>

#include "device/haptic_device.h"

namespace touchmend::device {

struct Waypoint {
  double t = 0;  //!< seconds after open()
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  std::uint32_t buttons = 0;
};

struct SimulatedOptions {
  double mass = 0.05;             //!< kg, effector
  double device_damping = 0.5;    //!< N·s/m, friction of the mechanism
  double hand_stiffness = 300;    //!< N/m, the operator's grip
  double hand_damping = 4;        //!< N·s/m
  double substep_seconds = 1e-4;  //!< integration step
  bool virtual_clock = false;     //!< advance() moves time; else the steady clock
  bool start_unhomed = false;     //!< requires home() before it reports homed
  std::vector<Waypoint> script;   //!< empty: hold the initial target (or set_target)
  Eigen::Vector3d start = Eigen::Vector3d::Zero();
};

class SimulatedDevice final : public HapticDevice {
 public:
  explicit SimulatedDevice(SimulatedOptions options = {});

  DeviceStatus open() override;
  void close() override;
  const DeviceInfo& info() const override { return info_; }
  bool read(DeviceState& state) override;
  void write(const ForceCommand& command) override;
  std::int64_t now_ns() const override;
  std::string last_error() const override { return fault_ ? "injected fault" : ""; }
  void clear_error() override { fault_ = false; }

  //! Moves the virtual clock (virtual_clock mode only).
  void advance(std::int64_t ns) { virtual_now_ns_ += ns; }
  //! Drives the hand directly (used when there is no script). Thread-safe.
  void set_target(const Eigen::Vector3d& target, std::uint32_t buttons);
  //! The homing gesture.
  void home() { homed_ = true; }
  // Fault injection for tests.
  void inject_stall(bool stalled) { stalled_ = stalled; }
  void inject_unhome() { homed_ = false; }
  void inject_fault() { fault_ = true; }
  //! The force the output stage applied in the last sub-step (after expiry).
  const Eigen::Vector3d& applied_force() const { return applied_; }

 private:
  void step_to(std::int64_t t);
  Eigen::Vector3d target_at(double seconds, std::uint32_t& buttons) const;

  SimulatedOptions options_;
  DeviceInfo info_;
  bool open_ = false;
  std::int64_t virtual_now_ns_ = 0;
  std::int64_t open_ns_ = 0;
  std::int64_t sim_ns_ = 0;
  std::uint64_t sequence_ = 0;
  Eigen::Vector3d position_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d velocity_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d applied_ = Eigen::Vector3d::Zero();
  std::uint32_t buttons_ = 0;
  ForceCommand command_;
  std::atomic<double> target_x_{0}, target_y_{0}, target_z_{0};
  std::atomic<std::uint32_t> target_buttons_{0};
  bool homed_ = true;
  bool stalled_ = false;
  bool fault_ = false;
  DeviceState stalled_state_;
};

}  // namespace touchmend::device
