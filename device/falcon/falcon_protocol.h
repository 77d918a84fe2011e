#pragma once

//! \file falcon_protocol.h
//! \brief Novint Falcon I/O packets (firmware "nVent" protocol), a clean-room codec from the
//! protocol facts in HAPTICS.md §2.7–§2.8. Pure functions, no I/O.
//!
//! \details Both directions are 16 bytes: '<', three signed 16-bit values as four nibbles
//! each (least significant first, every nibble + 0x41), one flags byte (+0x41), one unused
//! byte (0x41), '>'. Host → device: motor commands, LED and homing bits. Device → host:
//! encoder counts, grip buttons (bits 0–3) and per-axis homed flags (bits 4–6). Bulk-IN
//! transfers start with two FTDI status bytes that are not data; the stream decoder strips
//! them, reassembles packets split across transfers and resynchronises on garbage.

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

namespace touchmend::device::falcon {

using Packet = std::array<std::uint8_t, 16>;

inline constexpr std::uint8_t kStart = 0x3C;  // '<'
inline constexpr std::uint8_t kEnd = 0x3E;    // '>'
inline constexpr std::uint8_t kNibbleBase = 0x41;
inline constexpr int kMaxMotorCommand = 4095;  //!< usable DAC range (HAPTICS.md §2.7)

//! Host byte 13 bits.
enum HostFlags : std::uint8_t {
  kHoming = 0x01,
  kLedGreen = 0x02,
  kLedBlue = 0x04,
  kLedRed = 0x08,
};

struct Command {
  std::array<std::int16_t, 3> motors{0, 0, 0};
  std::uint8_t flags = 0;  //!< HostFlags
};

struct Report {
  std::array<std::int16_t, 3> encoders{0, 0, 0};
  std::uint8_t buttons = 0;  //!< bits 0-3
  std::uint8_t homed = 0;    //!< bits 0-2: axis 1 (top), 2 (right), 3 (left)
  bool all_homed() const { return homed == 0x7; }
};

//! Encodes a command. Motor values outside ±kMaxMotorCommand are clamped (the caller scales
//! the three together beforehand, which keeps the force direction).
Packet encode_command(const Command& command);
//! Decodes a host packet (for tests and the fake transport).
std::optional<Command> decode_command(std::span<const std::uint8_t> bytes);
//! Decodes a device report; nullopt if the framing or any nibble is out of range.
std::optional<Report> decode_report(std::span<const std::uint8_t> bytes);
//! Builds a device report (for the fake transport and tests).
Packet encode_report(const Report& report);

//! Reassembles device reports from bulk-IN transfers.
class ReportStream {
 public:
  //! Feeds one USB transfer (with its two status bytes); appends every complete, valid
  //! report to \p out.
  void feed_transfer(std::span<const std::uint8_t> transfer, std::vector<Report>& out);
  //! Feeds payload bytes (status bytes already removed).
  void feed_payload(std::span<const std::uint8_t> payload, std::vector<Report>& out);
  std::uint64_t dropped_bytes() const { return dropped_; }
  std::uint64_t reports() const { return reports_; }
  std::size_t pending() const { return size_; }

 private:
  std::array<std::uint8_t, 64> buffer_{};
  std::size_t size_ = 0;
  std::uint64_t dropped_ = 0;
  std::uint64_t reports_ = 0;
};

}  // namespace touchmend::device::falcon
