// Falcon: packet codec (recorded HDAL packets and synthetic ones from HAPTICS.md §2.11),
// stream reassembly, kinematics, the firmware handshake and the driver's I/O loop, all
// against a fake device at the packet level (no hardware here).

#include <deque>
#include <numbers>
#include <random>
#include <thread>

#include <gtest/gtest.h>

#include "device/falcon/falcon_device.h"
#include "device/falcon/falcon_firmware.h"
#include "device/falcon/falcon_kinematics.h"
#include "device/falcon/falcon_protocol.h"
#include "device/falcon/libusb_transport.h"

namespace touchmend::device::falcon {
namespace {

Packet bytes(std::initializer_list<int> list) {
  Packet p{};
  std::size_t i = 0;
  for (int b : list) p[i++] = static_cast<std::uint8_t>(b);
  return p;
}

TEST(FalconProtocol, RecordedHostPacketsDecodeToTheirMotorValues) {
  struct Case {
    Packet packet;
    std::array<std::int16_t, 3> motors;
  };
  const Case cases[] = {
      {bytes({0x3c, 0x46, 0x4a, 0x43, 0x41, 0x4c, 0x4e, 0x43, 0x41, 0x4f, 0x50, 0x43, 0x41, 0x45,
              0x41, 0x3e}),
       {661, 731, 766}},
      {bytes({0x3c, 0x50, 0x42, 0x46, 0x41, 0x4e, 0x4b, 0x46, 0x41, 0x47, 0x50, 0x46, 0x41, 0x45,
              0x41, 0x3e}),
       {1311, 1453, 1526}},
      {bytes({0x3c, 0x50, 0x50, 0x50, 0x41, 0x43, 0x45, 0x50, 0x41, 0x43, 0x4d, 0x50, 0x41, 0x45,
              0x41, 0x3e}),
       {4095, 3906, 4034}},
      {bytes({0x3c, 0x4d, 0x4b, 0x45, 0x50, 0x4c, 0x42, 0x41, 0x41, 0x42, 0x4b, 0x44, 0x41, 0x45,
              0x41, 0x3e}),
       {-2900, 27, 929}},
      {bytes({0x3c, 0x4a, 0x46, 0x4e, 0x50, 0x42, 0x4f, 0x4a, 0x41, 0x4b, 0x4c, 0x49, 0x50, 0x45,
              0x41, 0x3e}),
       {-679, 2529, -1862}},
      {bytes({0x3c, 0x50, 0x49, 0x42, 0x41, 0x42, 0x50, 0x44, 0x50, 0x50, 0x47, 0x45, 0x41, 0x45,
              0x41, 0x3e}),
       {399, -3087, 1135}},
  };
  for (const auto& c : cases) {
    const auto decoded = decode_command(c.packet);
    ASSERT_TRUE(decoded);
    EXPECT_EQ(decoded->motors, c.motors);
    EXPECT_EQ(decoded->flags, kLedBlue);
    Command again;
    again.motors = c.motors;
    again.flags = kLedBlue;
    EXPECT_EQ(encode_command(again), c.packet);
  }
}

TEST(FalconProtocol, SyntheticPacketsAndRanges) {
  EXPECT_EQ(encode_command({}), bytes({0x3c, 0x41, 0x41, 0x41, 0x41, 0x41, 0x41, 0x41, 0x41, 0x41,
                                       0x41, 0x41, 0x41, 0x41, 0x41, 0x3e}));
  Command green;
  green.flags = kLedGreen | kHoming;
  EXPECT_EQ(encode_command(green)[13], 0x44);
  Command red;
  red.motors = {1, -1, 4095};
  red.flags = kLedRed;
  EXPECT_EQ(encode_command(red), bytes({0x3c, 0x42, 0x41, 0x41, 0x41, 0x50, 0x50, 0x50, 0x50, 0x50,
                                        0x50, 0x50, 0x41, 0x49, 0x41, 0x3e}));
  // Out-of-range commands are clamped to the DAC range.
  Command big;
  big.motors = {-4096, 30000, -30000};
  const auto decoded = decode_command(encode_command(big));
  ASSERT_TRUE(decoded);
  EXPECT_EQ(decoded->motors, (std::array<std::int16_t, 3>{-4095, 4095, -4095}));
  // Every int16 survives a round trip on every slot.
  for (int v = -32768; v <= 32767; v += 7) {
    Report r;
    r.encoders = {static_cast<std::int16_t>(v), static_cast<std::int16_t>(-v - 1), 0};
    const auto back = decode_report(encode_report(r));
    ASSERT_TRUE(back);
    EXPECT_EQ(back->encoders, r.encoders);
  }
  // Device reports from the table.
  const auto homed = decode_report(bytes({0x3c, 0x41, 0x41, 0x41, 0x41, 0x41, 0x41, 0x41, 0x41,
                                          0x41, 0x41, 0x41, 0x41, 0xb1, 0x41, 0x3e}));
  ASSERT_TRUE(homed);
  EXPECT_TRUE(homed->all_homed());
  EXPECT_EQ(homed->buttons, 0);
  const auto one = decode_report(bytes({0x3c, 0x50, 0x50, 0x50, 0x50, 0x45, 0x47, 0x41, 0x41, 0x4d,
                                        0x4b, 0x45, 0x50, 0x5a, 0x41, 0x3e}));
  ASSERT_TRUE(one);
  EXPECT_EQ(one->encoders, (std::array<std::int16_t, 3>{-1, 100, -2900}));
  EXPECT_EQ(one->homed, 1);
  EXPECT_EQ(one->buttons, 9);
  // Framing and nibble ranges are checked.
  Packet bad = encode_report({});
  bad[5] = 0x40;
  EXPECT_FALSE(decode_report(bad));
  bad = encode_report({});
  bad[15] = 0x3d;
  EXPECT_FALSE(decode_report(bad));
}

TEST(FalconProtocol, StreamReassemblyResynchronises) {
  ReportStream stream;
  std::vector<Report> out;
  Report a, b;
  a.encoders = {10, -20, 30};
  b.encoders = {-1, 2, -3};
  b.homed = 7;
  const Packet pa = encode_report(a), pb = encode_report(b);
  // Split across two transfers, each with its two status bytes.
  std::vector<std::uint8_t> t1{0x31, 0x60};
  t1.insert(t1.end(), pa.begin(), pa.begin() + 9);
  std::vector<std::uint8_t> t2{0x31, 0x60};
  t2.insert(t2.end(), pa.begin() + 9, pa.end());
  stream.feed_transfer(t1, out);
  EXPECT_TRUE(out.empty());
  stream.feed_transfer(t2, out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].encoders, a.encoders);
  // Garbage, a truncated packet whose 16th byte happens to be a stale '>', then two packets
  // in one transfer: both good ones come out, nothing mis-parsed.
  out.clear();
  std::vector<std::uint8_t> t3{0x31, 0x60, 0x00, 0x13, 0x99};
  t3.insert(t3.end(), pa.begin(), pa.begin() + 14);  // truncated
  t3.insert(t3.end(), pb.begin(), pb.end());
  t3.insert(t3.end(), pa.begin(), pa.end());
  stream.feed_transfer(t3, out);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0].encoders, b.encoders);
  EXPECT_EQ(out[0].homed, 7);
  EXPECT_EQ(out[1].encoders, a.encoders);
  EXPECT_GE(stream.dropped_bytes(), 3u + 14u);
  // A transfer with only the status bytes carries nothing.
  std::vector<std::uint8_t> empty{0x31, 0x60};
  stream.feed_transfer(empty, out);
  EXPECT_EQ(out.size(), 2u);
}

TEST(FalconProtocol, RandomBytesNeverYieldAnInvalidReportAndGarbageNeverHidesAPacket) {
  std::mt19937 rng(17);
  std::uniform_int_distribution<int> byte(0, 255), size(0, 64);
  ReportStream stream;
  std::vector<Report> out;
  for (int i = 0; i < 20000; ++i) {
    std::vector<std::uint8_t> transfer(static_cast<std::size_t>(size(rng)));
    for (auto& b : transfer) b = static_cast<std::uint8_t>(byte(rng));
    // Bias toward the framing bytes so partial packets are common.
    if (!transfer.empty() && i % 3 == 0) transfer[transfer.size() / 2] = kStart;
    stream.feed_transfer(transfer, out);
  }
  for (const Report& r : out) {
    EXPECT_LE(r.homed, 7);
    EXPECT_LE(r.buttons, 15);
    const auto again = decode_report(encode_report(r));
    ASSERT_TRUE(again);
    EXPECT_EQ(again->encoders, r.encoders);
  }
  // Valid packets separated by garbage without a start byte all come through, in order.
  ReportStream clean;
  std::vector<Report> got;
  std::vector<Report> sent;
  std::vector<std::uint8_t> payload;
  for (int i = 0; i < 500; ++i) {
    const int garbage = size(rng) % 7;
    for (int g = 0; g < garbage; ++g) {
      std::uint8_t b = static_cast<std::uint8_t>(byte(rng));
      if (b == kStart) b = 0x00;
      payload.push_back(b);
    }
    Report r;
    r.encoders = {static_cast<std::int16_t>(byte(rng) * 100 - 12800), static_cast<std::int16_t>(i),
                  static_cast<std::int16_t>(-i)};
    r.buttons = static_cast<std::uint8_t>(i % 16);
    r.homed = static_cast<std::uint8_t>(i % 8);
    sent.push_back(r);
    const Packet p = encode_report(r);
    payload.insert(payload.end(), p.begin(), p.end());
  }
  for (std::size_t at = 0; at < payload.size();) {
    const std::size_t n =
        std::min<std::size_t>(payload.size() - at, 1 + std::size_t(size(rng)) % 62);
    std::vector<std::uint8_t> transfer{0x31, 0x60};
    transfer.insert(transfer.end(), payload.begin() + static_cast<std::ptrdiff_t>(at),
                    payload.begin() + static_cast<std::ptrdiff_t>(at + n));
    clean.feed_transfer(transfer, got);
    at += n;
  }
  ASSERT_EQ(got.size(), sent.size());
  for (std::size_t i = 0; i < sent.size(); ++i) {
    EXPECT_EQ(got[i].encoders, sent[i].encoders);
    EXPECT_EQ(got[i].buttons, sent[i].buttons);
    EXPECT_EQ(got[i].homed, sent[i].homed);
  }
}

TEST(FalconKinematics, InverseAndForwardAgreeAndTheJacobianMatchesDifferences) {
  const Geometry g;
  EXPECT_NEAR(g.encoder_deg_per_count, 0.036435, 1e-6);
  int tested = 0;
  for (double x = -0.03; x <= 0.031; x += 0.015)
    for (double y = -0.03; y <= 0.031; y += 0.015)
      for (double z = 0.09; z <= 0.161; z += 0.0175) {
        const Eigen::Vector3d p(x, y, z);
        Angles a;
        ASSERT_TRUE(inverse_kinematics(g, p, a)) << p.transpose();
        const ForwardResult fk = forward_kinematics(g, a, Eigen::Vector3d(0, 0, 0.11));
        EXPECT_TRUE(fk.converged) << p.transpose();
        EXPECT_LE(fk.iterations, 15);
        EXPECT_LT((fk.position - p).norm(), 1e-9) << p.transpose();
        Eigen::Matrix3d D;
        ASSERT_TRUE(angle_jacobian(g, p, D));
        for (int k = 0; k < 3; ++k) {
          const double h = 1e-7;
          Angles plus, minus;
          ASSERT_TRUE(inverse_kinematics(g, p + h * Eigen::Vector3d::Unit(k), plus));
          ASSERT_TRUE(inverse_kinematics(g, p - h * Eigen::Vector3d::Unit(k), minus));
          const Eigen::Vector3d numeric = (plus - minus) / (2 * h);
          EXPECT_LT((numeric - D.col(k)).norm(), 1e-5 * (1 + D.col(k).norm()));
        }
        // Encoder counts round-trip through the angle formula.
        const Eigen::Vector3d counts = encoders_from_angles(g, a);
        std::array<std::int16_t, 3> enc{};
        for (int i = 0; i < 3; ++i)
          enc[static_cast<std::size_t>(i)] = static_cast<std::int16_t>(std::lround(counts[i]));
        const Angles back = angles_from_encoders(g, enc);
        EXPECT_LT((back - a).cwiseAbs().maxCoeff(),
                  0.5 * g.encoder_deg_per_count * std::numbers::pi / 180 + 1e-12);
        ++tested;
      }
  EXPECT_GT(tested, 100);
  // Out of reach: no solution, not NaN.
  Angles far;
  EXPECT_FALSE(inverse_kinematics(g, Eigen::Vector3d(0, 0, 0.5), far));
}

TEST(FalconKinematics, ForcesBecomeBoundedCommandsThatKeepTheirDirection) {
  const Geometry g;
  const Eigen::Vector3d p(0.01, -0.005, 0.12);
  std::array<std::int16_t, 3> small{}, large{};
  bool scaled = false;
  ASSERT_TRUE(motor_commands(g, p, Eigen::Vector3d(0.3, -0.2, 0.5), 10000, small, &scaled));
  EXPECT_FALSE(scaled);
  ASSERT_TRUE(motor_commands(g, p, Eigen::Vector3d(30, -20, 50), 10000, large, &scaled));
  EXPECT_TRUE(scaled);
  int largest = 0;
  for (auto c : large) largest = std::max(largest, std::abs(int(c)));
  EXPECT_EQ(largest, kMaxMotorCommand);
  // Uniform scaling: the ratios of the three commands are the same.
  for (int i = 0; i < 3; ++i)
    EXPECT_NEAR(
        double(large[static_cast<std::size_t>(i)]) / kMaxMotorCommand,
        double(small[static_cast<std::size_t>(i)]) /
            std::max({std::abs(int(small[0])), std::abs(int(small[1])), std::abs(int(small[2]))}),
        2e-3);
  std::array<std::int16_t, 3> none{};
  EXPECT_FALSE(motor_commands(g, p, Eigen::Vector3d(NAN, 0, 0), 10000, none));
  EXPECT_EQ(none, (std::array<std::int16_t, 3>{0, 0, 0}));
}

//! A Falcon at the packet level: answers the firmware handshake, echoes uploads, and in
//! normal mode answers each command with a report of its encoders.
class FakeFalcon final : public Transport {
 public:
  bool firmware_loaded = false;
  bool echo_corrupt_at_chunk = false;
  int handshake_failures = 0;  // handshake probes to ignore first
  bool homed = false;
  Eigen::Vector3d position{0.005, -0.01, 0.12};
  std::vector<Command> commands;
  std::vector<std::pair<FtdiRequest, std::uint16_t>> controls;
  std::size_t firmware_bytes = 0;

  DeviceStatus control(FtdiRequest request, std::uint16_t value) override {
    std::lock_guard lock(mutex_);
    controls.emplace_back(request, value);
    if (request == FtdiRequest::BaudDivisor) baud_ = value;
    return {};
  }
  DeviceStatus bulk_write(std::span<const std::uint8_t> data) override {
    std::lock_guard lock(mutex_);
    if (baud_ == 0x4138) {  // handshake
      if (data.size() == 3 && data[0] == 0x0A && data[1] == 0x43 && data[2] == 0x0D) {
        if (handshake_failures > 0) {
          --handshake_failures;
          pending_.push_back({0x31, 0x60});
        } else {
          pending_.push_back({0x31, 0x60, 0x0A, 0x44, 0x2C, 0x0D});
        }
      }
      return {};
    }
    if (baud_ == 0x0015) {  // loader
      if (data.size() == 1 && data[0] == 0x41 && firmware_bytes == 0 && !loader_started_) {
        loader_started_ = true;
        pending_.push_back({0x31, 0x60, 0x41});
        return {};
      }
      std::vector<std::uint8_t> echo{0x31, 0x60};
      echo.insert(echo.end(), data.begin(), data.end());
      if (echo_corrupt_at_chunk && firmware_bytes > 100) echo.back() ^= 0xFF;
      firmware_bytes += data.size();
      pending_.push_back(echo);
      firmware_loaded = true;
      return {};
    }
    if (!firmware_loaded) return {};  // no firmware: silence
    const auto c = decode_command(data);
    if (!c) return DeviceStatus::failure("fake: bad packet");
    commands.push_back(*c);
    Report r;
    Angles a;
    inverse_kinematics(geometry_, position, a);
    const Eigen::Vector3d enc = encoders_from_angles(geometry_, a);
    for (int i = 0; i < 3; ++i)
      r.encoders[static_cast<std::size_t>(i)] = static_cast<std::int16_t>(std::lround(enc[i]));
    r.homed = homed ? 7 : 0;
    const Packet p = encode_report(r);
    std::vector<std::uint8_t> t{0x31, 0x60};
    t.insert(t.end(), p.begin(), p.end());
    pending_.push_back(t);
    return {};
  }
  DeviceStatus bulk_read(std::span<std::uint8_t> buffer, std::size_t& received, int) override {
    std::lock_guard lock(mutex_);
    received = 0;
    if (pending_.empty()) {
      buffer[0] = 0x31;
      buffer[1] = 0x60;
      received = 2;
      return {};
    }
    auto& front = pending_.front();
    received = std::min(front.size(), buffer.size());
    std::copy(front.begin(), front.begin() + static_cast<std::ptrdiff_t>(received), buffer.begin());
    pending_.pop_front();
    return {};
  }
  std::vector<Command> commands_copy() {
    std::lock_guard lock(mutex_);
    return commands;
  }
  void set_homed(bool h) {
    std::lock_guard lock(mutex_);
    homed = h;
  }

 private:
  std::mutex mutex_;
  Geometry geometry_;
  std::uint16_t baud_ = 0x0002;
  bool loader_started_ = false;
  std::deque<std::vector<std::uint8_t>> pending_;
};

TEST(FalconFirmware, HandshakeUploadAndEchoCheck) {
  std::vector<std::uint8_t> image(7914);
  for (std::size_t i = 0; i < image.size(); ++i) image[i] = static_cast<std::uint8_t>(i * 7);
  FakeFalcon fake;
  fake.handshake_failures = 5;
  std::size_t last_progress = 0;
  const DeviceStatus s = load_firmware(fake, image, [&](std::size_t sent, std::size_t total) {
    EXPECT_EQ(total, image.size());
    EXPECT_GT(sent, last_progress);
    last_progress = sent;
  });
  ASSERT_TRUE(s.ok) << s.message;
  EXPECT_EQ(fake.firmware_bytes, image.size());
  EXPECT_EQ(last_progress, image.size());  // last chunk 7914 mod 62 = 40 bytes
  // Normal mode afterwards: 1 ms latency, 1.5 Mbaud.
  ASSERT_GE(fake.controls.size(), 4u);
  EXPECT_EQ(fake.controls[fake.controls.size() - 4],
            std::make_pair(FtdiRequest::LatencyTimer, std::uint16_t(1)));
  EXPECT_TRUE(firmware_running(fake));

  FakeFalcon corrupt;
  corrupt.echo_corrupt_at_chunk = true;
  const DeviceStatus bad = load_firmware(corrupt, image);
  EXPECT_FALSE(bad.ok);
  EXPECT_NE(bad.message.find("echo"), std::string::npos) << bad.message;

  FakeFalcon deaf;
  deaf.handshake_failures = 1000;
  const DeviceStatus none = load_firmware(deaf, image);
  EXPECT_FALSE(none.ok);
  EXPECT_NE(none.message.find("handshake"), std::string::npos) << none.message;
  EXPECT_FALSE(firmware_running(deaf, 3));
}

TEST(FalconDevice, NoFirmwareAndNoFileIsAClearError) {
  auto fake = std::make_unique<FakeFalcon>();
  FalconDevice device({}, std::move(fake));
  const DeviceStatus s = device.open();
  EXPECT_FALSE(s.ok);
  EXPECT_NE(s.message.find("--falcon-firmware"), std::string::npos) << s.message;
}

TEST(FalconDevice, IoLoopHomesReportsPositionsAndNeverForcesUnhomed) {
  auto owned = std::make_unique<FakeFalcon>();
  FakeFalcon& fake = *owned;
  fake.firmware_loaded = true;
  FalconDevice device({}, std::move(owned));
  ASSERT_TRUE(device.open().ok);
  // Unhomed: the state says so, and a force request sends nothing but zero with homing set.
  DeviceState state;
  for (int i = 0; i < 2000 && !device.read(state); ++i)
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  ASSERT_TRUE(device.read(state));
  EXPECT_FALSE(state.homed);
  device.write({Eigen::Vector3d(0, 0, 1.0), steady_now_ns() + 1'000'000'000});
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  for (const Command& c : fake.commands_copy()) {
    EXPECT_EQ(c.motors, (std::array<std::int16_t, 3>{0, 0, 0}));
    if (c.flags != 0) {  // (flags 0: open()'s firmware probe)
      EXPECT_TRUE(c.flags & kHoming);
    }
  }
  // Homed: the position comes out of forward kinematics, and forces reach the motors.
  fake.set_homed(true);
  bool homed = false;
  for (int i = 0; i < 500 && !homed; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
    homed = device.read(state) && state.homed;
  }
  ASSERT_TRUE(homed);
  EXPECT_LT((state.position - fake.position).norm(), 1e-4);  // within an encoder count or so
  device.write({Eigen::Vector3d(0, 0, 1.0), steady_now_ns() + 1'000'000'000});
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  const auto commands = fake.commands_copy();
  ASSERT_FALSE(commands.empty());
  const Command& last = commands.back();
  EXPECT_NE(last.motors, (std::array<std::int16_t, 3>{0, 0, 0}));
  EXPECT_EQ(last.flags & kHoming, 0);
  for (const Command& c : commands)
    for (auto m : c.motors) EXPECT_LE(std::abs(int(m)), kMaxMotorCommand);
  // An expired command gives zero (the watchdog in the output stage).
  device.write({Eigen::Vector3d(0, 0, 1.0), steady_now_ns() - 1});
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  EXPECT_EQ(fake.commands_copy().back().motors, (std::array<std::int16_t, 3>{0, 0, 0}));
  // Homing lost: zero at once and the state is no longer homed.
  device.write({Eigen::Vector3d(0, 0, 1.0), steady_now_ns() + 1'000'000'000});
  fake.set_homed(false);
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  EXPECT_EQ(fake.commands_copy().back().motors, (std::array<std::int16_t, 3>{0, 0, 0}));
  ASSERT_TRUE(device.read(state));
  EXPECT_FALSE(state.homed);
  device.close();
  // Shutdown packets: zero force.
  EXPECT_EQ(fake.commands_copy().back().motors, (std::array<std::int16_t, 3>{0, 0, 0}));
}

TEST(FalconDevice, NoDeviceOnThisMachineIsReportedCleanly) {
  std::string error;
  const auto found = list_falcons(error);
  // Ask for one Falcon more than there are: none here (this machine has no USB devices), or
  // an index past the attached ones on a machine with a Falcon. Either way a clear refusal.
  FalconOptions options;
  options.index = static_cast<int>(found.size());
  FalconDevice device(options);
  const DeviceStatus s = device.open();
  EXPECT_FALSE(s.ok);
  if (found.empty()) {
    EXPECT_NE(s.message.find("no Novint Falcon found"), std::string::npos) << s.message;
  } else {
    EXPECT_NE(s.message.find("no Falcon with index"), std::string::npos) << s.message;
  }
  EXPECT_NE(describe_libusb_error(-3).find("udev"), std::string::npos);  // LIBUSB_ERROR_ACCESS
}

}  // namespace
}  // namespace touchmend::device::falcon
