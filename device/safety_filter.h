#pragma once

//! \file safety_filter.h
//! \brief The safety wrapper every device is used through (HAPTICS.md §5.3).
//!
//! \details Rules, in the order they apply to each command:
//!  - zero force until armed; arming needs the device homed, its state fresh and the
//!    requested force below `small_force` for `small_force_ticks` writes (CHAI3D's gate);
//!  - on arming, forces ramp in over `ramp_seconds` with extra damping;
//!  - a non-finite request is replaced by zero (counted; `nan_fault_after` in a row faults);
//!  - the magnitude is clamped to the cap keeping its direction;
//!  - the change per write is limited to cap / `slew_fraction_inverse` (a full step takes ten
//!    ticks, like VRPN's recovery cycles);
//!  - a stale device state (older than `stale_ns`) gives zero force;
//!  - homing loss or a device fault disarm at once (re-arming is the user's); a speed above
//!    `velocity_limit` cuts the force at once and re-arms by itself once slow again (gate,
//!    then ramp);
//!  - every command carries an expiry (`watchdog_ns`): if the loop stalls, the driver's
//!    output stage drops to zero by itself;
//!  - zero on open, close and any fault.
//! The filter is not thread-safe: one haptic thread reads and writes through it; arm() and
//! disarm() requests from other threads go through atomics.

#include <atomic>
#include <cstdint>

#include "device/haptic_device.h"

namespace touchmend::device {

struct SafetyOptions {
  double force_cap = 0;                  //!< N; 0 = the device's max_force
  double small_force = 0.2;              //!< N, arming gate
  int small_force_ticks = 3;             //!< consecutive small requests before arming
  double ramp_seconds = 1.0;             //!< force ramp-in after arming
  int slew_fraction_inverse = 10;        //!< |ΔF| per write <= cap / this
  std::int64_t stale_ns = 2'000'000;     //!< state older than this: zero force
  std::int64_t watchdog_ns = 3'000'000;  //!< a command expires after this
  double velocity_limit = 1.0;           //!< m/s; above it: zero and disarm
  int nan_fault_after = 10;              //!< non-finite requests in a row before a fault
};

struct SafetyCounters {
  std::uint64_t clamped = 0;
  std::uint64_t slew_limited = 0;
  std::uint64_t non_finite = 0;
  std::uint64_t stale = 0;
  std::uint64_t velocity_trips = 0;
  std::uint64_t homing_losses = 0;
  std::uint64_t faults = 0;
};

enum class ArmState { Disarmed, WaitingForSmallForce, Ramping, Armed, Faulted };
const char* to_string(ArmState state);

//! Stiffness and damping a renderer may use on this device (HAPTICS.md §5.3 rule 5).
struct Gains {
  double stiffness = 0;
  double damping = 0;
  bool capped = false;
};
Gains admit_gains(const DeviceInfo& info, double stiffness, double damping);

class SafetyFilter final : public HapticDevice {
 public:
  SafetyFilter(HapticDevice& inner, SafetyOptions options = {});

  DeviceStatus open() override;
  void close() override;
  const DeviceInfo& info() const override { return inner_.info(); }
  bool read(DeviceState& state) override;
  void write(const ForceCommand& command) override;
  std::int64_t now_ns() const override { return inner_.now_ns(); }
  std::string last_error() const override;
  void clear_error() override;

  //! Requests forces (granted once the gate passes). Thread-safe.
  void arm() { arm_requested_.store(true, std::memory_order_release); }
  //! Zero force from the next write on. Thread-safe.
  void disarm() { arm_requested_.store(false, std::memory_order_release); }
  ArmState arm_state() const { return state_.load(std::memory_order_acquire); }
  //! The force actually sent by the last write.
  const Eigen::Vector3d& last_output() const { return last_output_; }
  //! Written by the haptic thread only; read elsewhere for display (approximate).
  const SafetyCounters& counters() const { return counters_; }
  double force_cap() const { return cap_; }

 private:
  void fault(const char* why);
  void send(const Eigen::Vector3d& force, std::int64_t now);

  HapticDevice& inner_;
  SafetyOptions options_;
  double cap_ = 0;
  std::atomic<bool> arm_requested_{false};
  std::atomic<ArmState> state_{ArmState::Disarmed};
  int small_ticks_ = 0;
  int non_finite_in_row_ = 0;
  std::int64_t ramp_start_ns_ = 0;
  bool have_state_ = false;
  bool was_homed_ = false;
  DeviceState last_state_;
  Eigen::Vector3d last_output_ = Eigen::Vector3d::Zero();
  SafetyCounters counters_;
  const char* fault_reason_ = nullptr;
};

}  // namespace touchmend::device
