#pragma once

//! \file haptic_device.h
//! \brief One interface for every haptic device (HAPTICS.md §5.2): simulated, replay and the
//! Novint Falcon over libusb. The haptic loop reaches a device only through SafetyFilter.
//!
//! \details Reading never blocks and writing never blocks: a driver with its own I/O thread
//! publishes its newest state and consumes the newest command. Nothing throws across this
//! boundary; failures are reported as DeviceStatus values and last_error().

#include <cstdint>
#include <string>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace touchmend::device {

//! Result of a device operation: ok, or a message a user can act on.
struct DeviceStatus {
  bool ok = true;
  std::string message;
  static DeviceStatus failure(std::string why) { return {false, std::move(why)}; }
};

struct DeviceInfo {
  std::string kind;  //!< "sim", "replay", "falcon"
  std::string name;  //!< human-readable, with index/serial/file where it helps
  Eigen::AlignedBox3d workspace{Eigen::Vector3d(-0.05, -0.05, -0.05),
                                Eigen::Vector3d(0.05, 0.05, 0.05)};  //!< metres, device frame
  double max_force = 3.0;                                            //!< N, continuous
  double max_stiffness = 1000;                                       //!< N/m at the nominal rate
  double max_damping = 5;                                            //!< N·s/m
  int position_dof = 3;
  int force_dof = 3;  //!< 0 for a device without actuators (replay)
  int buttons = 1;
  bool requires_homing = false;
  double nominal_rate_hz = 1000;
};

//! The newest state of a device.
struct DeviceState {
  std::int64_t timestamp_ns = 0;  //!< steady clock (or the device's virtual clock)
  std::uint64_t sequence = 0;     //!< increases with every new sample from the device
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  //!< metres, device frame
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();  //!< m/s (filtered by the driver)
  std::uint32_t buttons = 0;                           //!< bit i = button i pressed
  bool homed = true;
  bool faulted = false;
};

//! A force for the device. The driver's output stage applies it until expires_ns and sends
//! zero afterwards (the watchdog for a stalled haptic loop, HAPTICS.md §5.3 rule 7).
struct ForceCommand {
  Eigen::Vector3d force = Eigen::Vector3d::Zero();  //!< N, device frame
  std::int64_t expires_ns = 0;
};

class HapticDevice {
 public:
  virtual ~HapticDevice() = default;
  //! Opens the device; the output is zero force after a successful open.
  virtual DeviceStatus open() = 0;
  //! Sends zero force, then releases the device. Safe to call twice.
  virtual void close() = 0;
  virtual const DeviceInfo& info() const = 0;
  //! The newest state; false when none has arrived yet. Never blocks.
  virtual bool read(DeviceState& state) = 0;
  //! Never blocks. A device without actuators ignores it.
  virtual void write(const ForceCommand& command) = 0;
  //! Device time now (the clock of DeviceState::timestamp_ns).
  virtual std::int64_t now_ns() const = 0;
  //! The last fault, empty if none.
  virtual std::string last_error() const = 0;
  //! Clears a latched fault (the user re-arms afterwards).
  virtual void clear_error() = 0;
};

//! Steady-clock nanoseconds (the clock of the real-time drivers).
std::int64_t steady_now_ns();

}  // namespace touchmend::device
