#include "device/falcon/falcon_firmware.h"

#include <algorithm>
#include <array>
#include <vector>

#include <fmt/format.h>

#include "device/falcon/falcon_protocol.h"

namespace touchmend::device::falcon {
namespace {

DeviceStatus controls(Transport& t,
                      std::initializer_list<std::pair<FtdiRequest, std::uint16_t>> list) {
  for (const auto& [request, value] : list) {
    if (DeviceStatus s = t.control(request, value); !s.ok) return s;
  }
  return {};
}

}  // namespace

DeviceStatus set_normal_mode(Transport& t) {
  return controls(t, {{FtdiRequest::LatencyTimer, 1},
                      {FtdiRequest::BaudDivisor, 0x0002},
                      {FtdiRequest::Reset, 1},
                      {FtdiRequest::Reset, 2}});
}

DeviceStatus set_firmware_mode(Transport& t) {
  // A 16 ms latency timer: with 1 ms the handshake replies tend to arrive split and fail.
  if (DeviceStatus s = controls(t, {{FtdiRequest::Reset, 1},
                                    {FtdiRequest::Reset, 2},
                                    {FtdiRequest::LatencyTimer, 16},
                                    {FtdiRequest::BaudDivisor, 0x4138},
                                    {FtdiRequest::LineProperties, 0x0008},
                                    {FtdiRequest::FlowControl, 0},
                                    {FtdiRequest::ModemControl, 0x0200},
                                    {FtdiRequest::ModemControl, 0x0100},
                                    {FtdiRequest::ModemControl, 0x0101}});
      !s.ok)
    return s;
  static constexpr std::array<std::uint8_t, 3> kProbe{0x0A, 0x43, 0x0D};
  static constexpr std::array<std::uint8_t, 4> kAnswer{0x0A, 0x44, 0x2C, 0x0D};
  std::array<std::uint8_t, 512> buffer{};
  bool answered = false;
  for (int attempt = 0; attempt < kHandshakeTries && !answered; ++attempt) {
    if (DeviceStatus s = t.bulk_write(kProbe); !s.ok) return s;
    std::size_t n = 0;
    if (DeviceStatus s = t.bulk_read(buffer, n, 100); !s.ok) return s;
    // After the two status bytes: "\n D , \r" (Linux), or with a leading 0x00 (macOS).
    const std::span<const std::uint8_t> payload(buffer.data() + std::min<std::size_t>(2, n),
                                                n > 2 ? n - 2 : 0);
    if (payload.size() == 4 && std::equal(kAnswer.begin(), kAnswer.end(), payload.begin()))
      answered = true;
    if (payload.size() == 5 && payload[0] == 0x00 &&
        std::equal(kAnswer.begin(), kAnswer.end(), payload.begin() + 1))
      answered = true;
  }
  if (!answered)
    return DeviceStatus::failure(fmt::format(
        "the Falcon did not answer the firmware-mode handshake in {} tries (replug it and retry)",
        kHandshakeTries));
  if (DeviceStatus s =
          controls(t, {{FtdiRequest::ModemControl, 0x0100}, {FtdiRequest::BaudDivisor, 0x0015}});
      !s.ok)
    return s;
  static constexpr std::array<std::uint8_t, 1> kLoader{0x41};
  if (DeviceStatus s = t.bulk_write(kLoader); !s.ok) return s;
  std::size_t n = 0;
  if (DeviceStatus s = t.bulk_read(std::span(buffer.data(), 3), n, 1000); !s.ok) return s;
  if (n < 3 || buffer[2] != 0x41)
    return DeviceStatus::failure("the Falcon's firmware loader did not echo 'A'");
  return {};
}

DeviceStatus load_firmware(Transport& t, std::span<const std::uint8_t> firmware,
                           const std::function<void(std::size_t, std::size_t)>& progress) {
  if (firmware.empty()) return DeviceStatus::failure("the firmware file is empty");
  if (DeviceStatus s = set_firmware_mode(t); !s.ok) return s;
  std::array<std::uint8_t, 64> buffer{};
  std::vector<std::uint8_t> echo;
  echo.reserve(kFirmwareChunk);
  for (std::size_t offset = 0; offset < firmware.size(); offset += kFirmwareChunk) {
    const auto chunk = firmware.subspan(offset, std::min(kFirmwareChunk, firmware.size() - offset));
    if (DeviceStatus s = t.bulk_write(chunk); !s.ok) return s;
    echo.clear();
    int idle = 0;
    while (echo.size() < chunk.size()) {
      std::size_t n = 0;
      if (DeviceStatus s = t.bulk_read(buffer, n, 1000); !s.ok) return s;
      if (n <= 2) {
        if (++idle > 20)
          return DeviceStatus::failure(fmt::format("firmware upload stalled at byte {} of {}",
                                                   offset + echo.size(), firmware.size()));
        continue;
      }
      idle = 0;
      echo.insert(echo.end(), buffer.begin() + 2, buffer.begin() + static_cast<std::ptrdiff_t>(n));
    }
    if (echo.size() != chunk.size() || !std::equal(chunk.begin(), chunk.end(), echo.begin()))
      return DeviceStatus::failure(
          fmt::format("firmware upload: the echo of bytes {}-{} does not match", offset,
                      offset + chunk.size() - 1));
    if (progress) progress(offset + chunk.size(), firmware.size());
  }
  return set_normal_mode(t);
}

bool firmware_running(Transport& t, int rounds) {
  ReportStream stream;
  std::vector<Report> reports;
  std::array<std::uint8_t, 64> buffer{};
  const Packet zero = encode_command({});
  for (int i = 0; i < rounds; ++i) {
    if (!t.bulk_write(zero).ok) return false;
    for (int reads = 0; reads < 4; ++reads) {
      std::size_t n = 0;
      if (!t.bulk_read(buffer, n, 5).ok) return false;
      stream.feed_transfer(std::span(buffer.data(), n), reports);
      if (!reports.empty()) return true;
    }
  }
  return false;
}

}  // namespace touchmend::device::falcon
