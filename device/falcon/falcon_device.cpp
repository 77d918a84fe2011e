#include "device/falcon/falcon_device.h"

#include <fstream>
#include <iterator>
#include <vector>

#include <fmt/format.h>

#include "device/falcon/falcon_firmware.h"
#include "device/falcon/falcon_protocol.h"
#include "device/falcon/libusb_transport.h"

namespace touchmend::device::falcon {

FalconDevice::FalconDevice(FalconOptions options, std::unique_ptr<Transport> transport)
    : options_(std::move(options)), transport_(std::move(transport)) {
  info_.kind = "falcon";
  info_.name = fmt::format("Novint Falcon #{}", options_.index);
  // Device frame: the kinematic frame, centred on the workspace (HAPTICS.md §2.10 uses
  // z ≈ 0.095–0.170 m; the centre is near z = 0.12).
  info_.workspace =
      Eigen::AlignedBox3d(Eigen::Vector3d(-0.05, -0.05, 0.07), Eigen::Vector3d(0.05, 0.05, 0.175));
  info_.max_force = options_.max_force;
  info_.max_stiffness = 3000;  // CHAI3D's spec table at 1 kHz
  info_.max_damping = 20;
  info_.buttons = 4;
  info_.requires_homing = true;
  info_.nominal_rate_hz = 1000;
}

FalconDevice::~FalconDevice() {
  close();
}

void FalconDevice::set_error(const std::string& message) {
  std::lock_guard lock(error_mutex_);
  error_ = message;
}

std::string FalconDevice::last_error() const {
  std::lock_guard lock(error_mutex_);
  return error_;
}

void FalconDevice::clear_error() {
  set_error("");
  faulted_.store(false, std::memory_order_release);
}

DeviceStatus FalconDevice::open() {
  if (running_.load()) return {};
  if (!transport_) {
    std::unique_ptr<LibusbTransport> usb;
    if (DeviceStatus s = LibusbTransport::open(options_.index, usb); !s.ok) return s;
    transport_ = std::move(usb);
  }
  if (DeviceStatus s = set_normal_mode(*transport_); !s.ok) return s;
  if (!firmware_running(*transport_)) {
    if (options_.firmware_file.empty()) {
      return DeviceStatus::failure(
          "the Falcon is not running its firmware (it is lost at power-off): pass "
          "--falcon-firmware FILE with the firmware from your Novint or libnifalcon "
          "installation (touchmend does not ship it)");
    }
    std::ifstream in(options_.firmware_file, std::ios::binary);
    if (!in)
      return DeviceStatus::failure("cannot read the firmware file " + options_.firmware_file);
    const std::vector<std::uint8_t> image{std::istreambuf_iterator<char>(in), {}};
    if (image.empty() || image.size() > 64 * 1024)
      return DeviceStatus::failure(fmt::format("{}: {} bytes is not a Falcon firmware image",
                                               options_.firmware_file, image.size()));
    DeviceStatus loaded;
    for (int attempt = 1; attempt <= options_.firmware_attempts; ++attempt) {
      loaded = load_firmware(*transport_, image);
      if (loaded.ok && firmware_running(*transport_)) break;
      if (loaded.ok) loaded = DeviceStatus::failure("the firmware was sent but does not answer");
    }
    if (!loaded.ok)
      return DeviceStatus::failure(fmt::format("firmware load failed after {} attempts: {}",
                                               options_.firmware_attempts, loaded.message));
  }
  commands_.publish(ForceCommand{});
  have_state_ = false;
  faulted_.store(false);
  running_.store(true);
  thread_ = std::thread([this] { io_loop(); });
  return {};
}

void FalconDevice::close() {
  if (!running_.exchange(false)) return;
  if (thread_.joinable()) thread_.join();
}

bool FalconDevice::read(DeviceState& state) {
  if (states_.update()) have_state_ = true;
  if (!have_state_) return false;
  state = states_.front();
  state.faulted = state.faulted || faulted_.load(std::memory_order_acquire);
  return true;
}

void FalconDevice::write(const ForceCommand& command) {
  commands_.publish(command);
}

void FalconDevice::io_loop() {
  ReportStream stream;
  std::vector<Report> reports;
  reports.reserve(8);
  std::array<std::uint8_t, 64> buffer{};
  Eigen::Vector3d position(0, 0, 0.11);  // FK seed: the origin itself is singular
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();
  bool have_position = false;
  bool homed = false;
  int missed = 0;
  std::uint64_t sequence = 0;
  std::int64_t last_ns = 0;
  ForceCommand command;
  while (running_.load(std::memory_order_acquire)) {
    if (commands_.update()) command = commands_.front();
    const std::int64_t now = steady_now_ns();
    const bool force_on = homed && have_position && now <= command.expires_ns &&
                          command.force.allFinite() && !faulted_.load(std::memory_order_acquire);
    Command out;
    if (force_on) {
      std::array<std::int16_t, 3> motors{};
      if (motor_commands(geometry_, position, command.force, options_.gain, motors))
        out.motors = motors;
    }
    const bool idle = out.motors == std::array<std::int16_t, 3>{0, 0, 0};
    out.flags =
        static_cast<std::uint8_t>(homed ? (idle ? kLedBlue : kLedGreen) : kHoming | kLedRed);
    if (DeviceStatus s = transport_->bulk_write(encode_command(out)); !s.ok) {
      set_error(s.message);
      faulted_.store(true, std::memory_order_release);
      break;
    }
    // One command, one report: read until it arrives or the cycle times out.
    reports.clear();
    const std::int64_t deadline = now + std::int64_t(options_.answer_timeout_ms) * 1'000'000;
    while (reports.empty() && steady_now_ns() < deadline) {
      std::size_t n = 0;
      if (DeviceStatus s = transport_->bulk_read(buffer, n, options_.answer_timeout_ms); !s.ok) {
        set_error(s.message);
        faulted_.store(true, std::memory_order_release);
        running_.store(false);
        break;
      }
      stream.feed_transfer(std::span(buffer.data(), n), reports);
    }
    dropped_bytes_.store(stream.dropped_bytes(), std::memory_order_relaxed);
    if (reports.empty()) {
      if (++missed >= options_.missed_cycles_fault && !faulted_.load()) {
        set_error(fmt::format("the Falcon did not answer for {} cycles", missed));
        faulted_.store(true, std::memory_order_release);
      }
      continue;
    }
    missed = 0;
    cycles_.fetch_add(1, std::memory_order_relaxed);
    const Report& r = reports.back();
    const bool now_homed = r.all_homed();
    if (homed && !now_homed) have_position = false;  // the coordinate system is gone
    homed = now_homed;
    const ForwardResult fk =
        forward_kinematics(geometry_, angles_from_encoders(geometry_, r.encoders), position);
    const std::int64_t t = steady_now_ns();
    if (fk.converged) {
      if (have_position && last_ns > 0 && t > last_ns) {
        // Velocity: an exponential filter over ~15 ms (CHAI3D's estimation window).
        const double dt = double(t - last_ns) * 1e-9;
        const double alpha = std::min(1.0, dt / 0.015);
        velocity += alpha * ((fk.position - position) / dt - velocity);
      }
      position = fk.position;
      have_position = homed;
    }
    last_ns = t;
    DeviceState& s = states_.back();
    s.timestamp_ns = t;
    s.sequence = ++sequence;
    s.position = position;
    s.velocity = velocity;
    s.buttons = r.buttons;
    s.homed = homed && have_position;
    s.faulted = faulted_.load(std::memory_order_acquire);
    states_.publish();
  }
  // Shutdown: zero force for several cycles, then LEDs off (the link must keep running while
  // the device is open; HAPTICS.md §5.3 rule 11).
  for (int i = 0; i < 5; ++i) {
    Command zero;
    zero.flags = i < 4 ? kLedRed : 0;
    if (!transport_->bulk_write(encode_command(zero)).ok) break;
    std::size_t n = 0;
    (void)transport_->bulk_read(buffer, n, 2);
  }
}

}  // namespace touchmend::device::falcon
