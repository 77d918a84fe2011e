#pragma once

//! \file falcon_device.h
//! \brief The Novint Falcon driver: a dedicated I/O thread runs the one-command-one-report
//! cycle (HAPTICS.md §2.8), turns encoder counts into positions (forward kinematics) and
//! forces into motor commands, and exchanges the newest state and command with the haptic
//! thread through triple buffers.
//!
//! \details Homing: every command carries the homing bit until all three axes report homed
//! (the user pulls the grip out, then pushes it in); no force is sent before that, and a
//! lost homed flag zeroes the motors at once. LEDs: red while unhomed, blue when homed, green
//! while a force is applied. The force→count gain is uncalibrated (HAPTICS.md §2.10), so the
//! default force cap is low (2 N). Ten consecutive cycles without an answer fault the device.

#include <atomic>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "device/falcon/falcon_kinematics.h"
#include "device/falcon/falcon_transport.h"
#include "device/triple_buffer.h"

namespace touchmend::device::falcon {

struct FalconOptions {
  int index = 0;
  std::string firmware_file;  //!< loaded only when the device does not run firmware yet
  double gain = 1800;         //!< motor counts per N·m of joint torque (uncalibrated)
  double max_force = 2.0;     //!< N, reported as DeviceInfo::max_force
  int answer_timeout_ms = 10;
  int missed_cycles_fault = 10;
  int firmware_attempts = 10;
};

class FalconDevice final : public HapticDevice {
 public:
  //! \p transport: null to open the index-th Falcon over libusb in open().
  explicit FalconDevice(FalconOptions options = {}, std::unique_ptr<Transport> transport = nullptr);
  ~FalconDevice() override;

  DeviceStatus open() override;
  void close() override;
  const DeviceInfo& info() const override { return info_; }
  bool read(DeviceState& state) override;
  void write(const ForceCommand& command) override;
  std::int64_t now_ns() const override { return steady_now_ns(); }
  std::string last_error() const override;
  void clear_error() override;

  std::uint64_t cycles() const { return cycles_.load(std::memory_order_relaxed); }
  std::uint64_t dropped_bytes() const { return dropped_bytes_.load(std::memory_order_relaxed); }

 private:
  void io_loop();
  void set_error(const std::string& message);

  FalconOptions options_;
  Geometry geometry_;
  DeviceInfo info_;
  std::unique_ptr<Transport> transport_;
  std::thread thread_;
  std::atomic<bool> running_{false};
  std::atomic<bool> faulted_{false};
  std::atomic<std::uint64_t> cycles_{0};
  std::atomic<std::uint64_t> dropped_bytes_{0};
  TripleBuffer<DeviceState> states_;
  TripleBuffer<ForceCommand> commands_;
  bool have_state_ = false;         // consumer side
  mutable std::mutex error_mutex_;  // errors are set by the I/O thread, read by the UI
  std::string error_;
};

}  // namespace touchmend::device::falcon
