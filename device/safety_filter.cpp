#include "device/safety_filter.h"

#include <algorithm>
#include <chrono>
#include <cmath>

namespace touchmend::device {

std::int64_t steady_now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

const char* to_string(ArmState state) {
  switch (state) {
    case ArmState::Disarmed:
      return "disarmed";
    case ArmState::WaitingForSmallForce:
      return "arming (waiting for a small force)";
    case ArmState::Ramping:
      return "ramping in";
    case ArmState::Armed:
      return "armed";
    case ArmState::Faulted:
      return "faulted";
  }
  return "?";
}

Gains admit_gains(const DeviceInfo& info, double stiffness, double damping) {
  Gains g;
  g.stiffness = std::isfinite(stiffness) ? std::clamp(stiffness, 0.0, info.max_stiffness) : 0.0;
  g.damping = std::isfinite(damping) ? std::clamp(damping, 0.0, info.max_damping) : 0.0;
  g.capped = g.stiffness != stiffness || g.damping != damping;
  return g;
}

SafetyFilter::SafetyFilter(HapticDevice& inner, SafetyOptions options)
    : inner_(inner), options_(options) {
  const double device_max = inner_.info().max_force;
  cap_ = options_.force_cap > 0 ? std::min(options_.force_cap, device_max) : device_max;
}

DeviceStatus SafetyFilter::open() {
  DeviceStatus s = inner_.open();
  state_.store(ArmState::Disarmed, std::memory_order_release);
  arm_requested_.store(false, std::memory_order_release);
  have_state_ = false;
  was_homed_ = false;
  last_output_.setZero();
  if (s.ok) inner_.write({Eigen::Vector3d::Zero(), inner_.now_ns() + options_.watchdog_ns});
  return s;
}

void SafetyFilter::close() {
  last_output_.setZero();
  inner_.write({Eigen::Vector3d::Zero(), 0});
  state_.store(ArmState::Disarmed, std::memory_order_release);
  inner_.close();
}

std::string SafetyFilter::last_error() const {
  std::string inner = inner_.last_error();
  if (!inner.empty()) return inner;
  return fault_reason_ ? fault_reason_ : "";
}

void SafetyFilter::clear_error() {
  inner_.clear_error();
  fault_reason_ = nullptr;
  non_finite_in_row_ = 0;
  if (state_.load(std::memory_order_acquire) == ArmState::Faulted)
    state_.store(ArmState::Disarmed, std::memory_order_release);
}

void SafetyFilter::fault(const char* why) {
  fault_reason_ = why;
  ++counters_.faults;
  arm_requested_.store(false, std::memory_order_release);
  state_.store(ArmState::Faulted, std::memory_order_release);
}

bool SafetyFilter::read(DeviceState& state) {
  if (!inner_.read(state)) return false;
  // Homing loss resets the device's coordinate system: positions before and after do not
  // agree, so any force computed from them is wrong (HAPTICS.md §2.9, §5.3 rule 8).
  if (was_homed_ && !state.homed) {
    ++counters_.homing_losses;
    arm_requested_.store(false, std::memory_order_release);
    if (state_.load(std::memory_order_acquire) != ArmState::Faulted)
      state_.store(ArmState::Disarmed, std::memory_order_release);
  }
  was_homed_ = state.homed;
  if (state.faulted) fault("the device reported a fault");
  if (!state.velocity.allFinite() || state.velocity.norm() > options_.velocity_limit) {
    // A force-type fault (HAPTICS.md §5.3 rule 10): zero at once, then re-arm by itself
    // through the gate (small force, and slow again) and the ramp.
    const ArmState s = state_.load(std::memory_order_acquire);
    if (s == ArmState::Ramping || s == ArmState::Armed) {
      ++counters_.velocity_trips;
      small_ticks_ = 0;
      state_.store(ArmState::WaitingForSmallForce, std::memory_order_release);
    }
  }
  last_state_ = state;
  have_state_ = true;
  return true;
}

void SafetyFilter::send(const Eigen::Vector3d& force, std::int64_t now) {
  last_output_ = force;
  inner_.write({force, now + options_.watchdog_ns});
}

void SafetyFilter::write(const ForceCommand& command) {
  const std::int64_t now = inner_.now_ns();
  Eigen::Vector3d request = command.force;
  if (!request.allFinite()) {
    ++counters_.non_finite;
    if (++non_finite_in_row_ >= options_.nan_fault_after) fault("non-finite force requests");
    request.setZero();
  } else {
    non_finite_in_row_ = 0;
  }
  const bool fresh = have_state_ && now - last_state_.timestamp_ns <= options_.stale_ns;
  if (have_state_ && !fresh) ++counters_.stale;

  // Arming state machine.
  ArmState state = state_.load(std::memory_order_acquire);
  const bool wanted = arm_requested_.load(std::memory_order_acquire);
  if (state != ArmState::Faulted) {
    if (!wanted) {
      state = ArmState::Disarmed;
    } else if (state == ArmState::Disarmed) {
      state = ArmState::WaitingForSmallForce;
      small_ticks_ = 0;
    }
    if (state == ArmState::WaitingForSmallForce) {
      const bool homed = have_state_ && last_state_.homed;
      const bool slow = have_state_ && last_state_.velocity.allFinite() &&
                        last_state_.velocity.norm() < 0.5 * options_.velocity_limit;
      small_ticks_ =
          (homed && fresh && slow && request.norm() < options_.small_force) ? small_ticks_ + 1 : 0;
      if (small_ticks_ >= options_.small_force_ticks) {
        state = ArmState::Ramping;
        ramp_start_ns_ = now;
      }
    }
    if (state == ArmState::Ramping && now - ramp_start_ns_ >= options_.ramp_seconds * 1e9)
      state = ArmState::Armed;
    state_.store(state, std::memory_order_release);
  }

  Eigen::Vector3d out = Eigen::Vector3d::Zero();
  if ((state == ArmState::Ramping || state == ArmState::Armed) && fresh) {
    out = request;
    if (state == ArmState::Ramping) {
      const double scale =
          options_.ramp_seconds > 0
              ? std::clamp(double(now - ramp_start_ns_) / (options_.ramp_seconds * 1e9), 0.0, 1.0)
              : 1.0;
      // Extra damping while forces come in (CHAI3D's force rise): 0.2 x the device's max.
      out = scale * out - (1.0 - scale) * 0.2 * info().max_damping * last_state_.velocity;
    }
    const double magnitude = out.norm();
    if (magnitude > cap_) {
      out *= cap_ / magnitude;  // keep the direction
      ++counters_.clamped;
    }
  }
  // The slew limit smooths changes while forces are on; disarming, homing loss, faults and a
  // stale state cut to zero at once (HAPTICS.md §7 T8: zero on the first packet after them).
  const bool on = (state == ArmState::Ramping || state == ArmState::Armed) && fresh;
  if (on && options_.slew_fraction_inverse > 0) {
    const double max_step = cap_ / options_.slew_fraction_inverse;
    const Eigen::Vector3d step = out - last_output_;
    if (step.norm() > max_step) {
      out = last_output_ + step * (max_step / step.norm());
      ++counters_.slew_limited;
    }
  }
  send(out, now);
}

}  // namespace touchmend::device
