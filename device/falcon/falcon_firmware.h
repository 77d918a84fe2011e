#pragma once

//! \file falcon_firmware.h
//! \brief Falcon link set-up: normal mode, the firmware-mode handshake and the firmware
//! upload with echo check (HAPTICS.md §2.5–§2.6), over any Transport.
//!
//! \details The firmware belongs to Novint and is never shipped: the user supplies the file
//! (from their own Novint or libnifalcon installation), and loading is skipped when the device
//! already runs firmware (it survives until power-off).

#include <functional>
#include <span>

#include "device/falcon/falcon_transport.h"

namespace touchmend::device::falcon {

inline constexpr std::size_t kFirmwareChunk = 62;
inline constexpr int kHandshakeTries = 100;

//! 1 ms latency timer, 1.5 Mbaud, purge both buffers.
DeviceStatus set_normal_mode(Transport& transport);

//! 9600 baud handshake ("\n C \r" answered by "\n D , \r"), then the loader's 'A' echo.
DeviceStatus set_firmware_mode(Transport& transport);

//! Sends \p firmware in 62-byte chunks, checking that every byte comes back, then returns the
//! link to normal mode. \p progress(sent, total) may be null.
DeviceStatus load_firmware(Transport& transport, std::span<const std::uint8_t> firmware,
                           const std::function<void(std::size_t, std::size_t)>& progress = {});

//! True if the device answers I/O packets (firmware running): up to \p rounds exchanges of a
//! zero command and a read.
bool firmware_running(Transport& transport, int rounds = 50);

}  // namespace touchmend::device::falcon
