#include "device/simulated_device.h"

#include <algorithm>

namespace touchmend::device {

SimulatedDevice::SimulatedDevice(SimulatedOptions options) : options_(std::move(options)) {
  info_.kind = "sim";
  info_.name = options_.script.empty() ? "simulated stylus" : "simulated stylus (scripted)";
  info_.workspace =
      Eigen::AlignedBox3d(Eigen::Vector3d::Constant(-0.1), Eigen::Vector3d::Constant(0.1));
  info_.max_force = 5.0;
  info_.max_stiffness = 2000;
  info_.max_damping = 10;
  info_.buttons = 2;
  info_.requires_homing = options_.start_unhomed;
  position_ = options_.start;
  target_x_ = options_.start.x();
  target_y_ = options_.start.y();
  target_z_ = options_.start.z();
}

std::int64_t SimulatedDevice::now_ns() const {
  return options_.virtual_clock ? virtual_now_ns_ : steady_now_ns();
}

DeviceStatus SimulatedDevice::open() {
  open_ = true;
  open_ns_ = now_ns();
  sim_ns_ = open_ns_;
  homed_ = !options_.start_unhomed;
  command_ = {};
  applied_.setZero();
  return {};
}

void SimulatedDevice::close() {
  command_ = {};
  applied_.setZero();
  open_ = false;
}

void SimulatedDevice::set_target(const Eigen::Vector3d& target, std::uint32_t buttons) {
  target_x_.store(target.x(), std::memory_order_relaxed);
  target_y_.store(target.y(), std::memory_order_relaxed);
  target_z_.store(target.z(), std::memory_order_relaxed);
  target_buttons_.store(buttons, std::memory_order_relaxed);
}

Eigen::Vector3d SimulatedDevice::target_at(double seconds, std::uint32_t& buttons) const {
  const auto& s = options_.script;
  if (s.empty()) {
    buttons = target_buttons_.load(std::memory_order_relaxed);
    return {target_x_.load(std::memory_order_relaxed), target_y_.load(std::memory_order_relaxed),
            target_z_.load(std::memory_order_relaxed)};
  }
  if (seconds <= s.front().t) {
    buttons = s.front().buttons;
    return s.front().position;
  }
  if (seconds >= s.back().t) {
    buttons = s.back().buttons;
    return s.back().position;
  }
  const auto next = std::upper_bound(s.begin(), s.end(), seconds,
                                     [](double t, const Waypoint& w) { return t < w.t; });
  const Waypoint& b = *next;
  const Waypoint& a = *(next - 1);
  const double u = b.t > a.t ? (seconds - a.t) / (b.t - a.t) : 1.0;
  buttons = a.buttons;
  return a.position + u * (b.position - a.position);
}

void SimulatedDevice::step_to(std::int64_t t) {
  const auto dt_ns = static_cast<std::int64_t>(options_.substep_seconds * 1e9);
  // A long gap (a paused test, a suspended process) is not integrated step by step.
  if (t - sim_ns_ > 200'000'000) sim_ns_ = t - 200'000'000;
  while (sim_ns_ + dt_ns <= t) {
    sim_ns_ += dt_ns;
    std::uint32_t buttons = 0;
    const Eigen::Vector3d target = target_at(double(sim_ns_ - open_ns_) * 1e-9, buttons);
    buttons_ = buttons;
    // The output stage: the command holds until it expires, then zero (the watchdog).
    applied_ = (sim_ns_ <= command_.expires_ns && command_.force.allFinite() && !fault_)
                   ? command_.force
                   : Eigen::Vector3d::Zero();
    const Eigen::Vector3d hand =
        options_.hand_stiffness * (target - position_) - options_.hand_damping * velocity_;
    const Eigen::Vector3d total = hand + applied_ - options_.device_damping * velocity_;
    const double dt = options_.substep_seconds;
    velocity_ += dt * total / options_.mass;  // semi-implicit Euler
    position_ += dt * velocity_;
    ++sequence_;
  }
}

bool SimulatedDevice::read(DeviceState& state) {
  if (!open_) return false;
  if (stalled_) {
    state = stalled_state_;
    return sequence_ > 0;
  }
  step_to(now_ns());
  state.timestamp_ns = sim_ns_;
  state.sequence = sequence_;
  state.position = position_;
  state.velocity = velocity_;
  state.buttons = buttons_;
  state.homed = homed_;
  state.faulted = fault_;
  stalled_state_ = state;
  return true;
}

void SimulatedDevice::write(const ForceCommand& command) {
  if (open_) command_ = command;
}

}  // namespace touchmend::device
