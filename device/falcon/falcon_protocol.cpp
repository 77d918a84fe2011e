#include "device/falcon/falcon_protocol.h"

#include <algorithm>
#include <cstring>

namespace touchmend::device::falcon {
namespace {

void put_value(Packet& p, std::size_t at, std::int16_t value) {
  const auto bits = static_cast<std::uint16_t>(value);
  for (std::size_t k = 0; k < 4; ++k)
    p[at + k] = static_cast<std::uint8_t>(kNibbleBase + ((bits >> (4 * k)) & 0xF));
}

bool get_value(std::span<const std::uint8_t> b, std::size_t at, std::int16_t& value) {
  std::uint16_t bits = 0;
  for (std::size_t k = 0; k < 4; ++k) {
    const std::uint8_t c = b[at + k];
    if (c < kNibbleBase || c > kNibbleBase + 0xF) return false;
    bits = static_cast<std::uint16_t>(bits | ((c - kNibbleBase) << (4 * k)));
  }
  value = static_cast<std::int16_t>(bits);
  return true;
}

}  // namespace

Packet encode_command(const Command& command) {
  Packet p{};
  p[0] = kStart;
  for (std::size_t i = 0; i < 3; ++i) {
    const int clamped = std::clamp<int>(command.motors[i], -kMaxMotorCommand, kMaxMotorCommand);
    put_value(p, 1 + 4 * i, static_cast<std::int16_t>(clamped));
  }
  p[13] = static_cast<std::uint8_t>(kNibbleBase + (command.flags & 0x0F));
  p[14] = kNibbleBase;
  p[15] = kEnd;
  return p;
}

std::optional<Command> decode_command(std::span<const std::uint8_t> b) {
  if (b.size() != 16 || b[0] != kStart || b[15] != kEnd) return std::nullopt;
  Command c;
  for (std::size_t i = 0; i < 3; ++i)
    if (!get_value(b, 1 + 4 * i, c.motors[i])) return std::nullopt;
  if (b[13] < kNibbleBase || b[13] > kNibbleBase + 0xF || b[14] != kNibbleBase) return std::nullopt;
  c.flags = static_cast<std::uint8_t>(b[13] - kNibbleBase);
  return c;
}

std::optional<Report> decode_report(std::span<const std::uint8_t> b) {
  if (b.size() != 16 || b[0] != kStart || b[15] != kEnd) return std::nullopt;
  Report r;
  for (std::size_t i = 0; i < 3; ++i)
    if (!get_value(b, 1 + 4 * i, r.encoders[i])) return std::nullopt;
  // Info byte: up to 0x41 + 0x7F (buttons in bits 0-3, homed flags in bits 4-6).
  if (b[13] < kNibbleBase || b[13] > kNibbleBase + 0x7F) return std::nullopt;
  if (b[14] < kNibbleBase || b[14] > kNibbleBase + 0xF) return std::nullopt;
  const auto info = static_cast<std::uint8_t>(b[13] - kNibbleBase);
  r.buttons = info & 0x0F;
  r.homed = (info >> 4) & 0x07;
  return r;
}

Packet encode_report(const Report& report) {
  Packet p{};
  p[0] = kStart;
  for (std::size_t i = 0; i < 3; ++i) put_value(p, 1 + 4 * i, report.encoders[i]);
  p[13] =
      static_cast<std::uint8_t>(kNibbleBase + ((report.homed & 7) << 4) + (report.buttons & 0xF));
  p[14] = kNibbleBase;
  p[15] = kEnd;
  return p;
}

void ReportStream::feed_transfer(std::span<const std::uint8_t> transfer, std::vector<Report>& out) {
  if (transfer.size() <= 2) return;  // status bytes only: no data this time
  feed_payload(transfer.subspan(2), out);
}

void ReportStream::feed_payload(std::span<const std::uint8_t> payload, std::vector<Report>& out) {
  for (const std::uint8_t byte : payload) {
    if (size_ == 0 && byte != kStart) {
      ++dropped_;  // garbage before a start byte
      continue;
    }
    buffer_[size_++] = byte;
    if (size_ < 16) continue;
    if (auto r = decode_report(std::span<const std::uint8_t>(buffer_.data(), 16))) {
      out.push_back(*r);
      ++reports_;
      size_ = 0;
      continue;
    }
    // Not a valid packet (a truncated one followed by the next, PR #30's case): drop the
    // first byte and rescan from the next start byte in what is buffered.
    std::size_t next = 1;
    while (next < size_ && buffer_[next] != kStart) ++next;
    dropped_ += next;
    std::memmove(buffer_.data(), buffer_.data() + next, size_ - next);
    size_ -= next;
  }
}

}  // namespace touchmend::device::falcon
