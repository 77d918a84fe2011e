#pragma once

//! \file falcon_transport.h
//! \brief Byte transport to a Falcon's FTDI chip: vendor control transfers and bulk I/O
//! (HAPTICS.md §2.2–§2.3). libusb implements it for hardware; tests use a fake device.

#include <cstdint>
#include <span>

#include "device/haptic_device.h"

namespace touchmend::device::falcon {

//! FTDI vendor requests (bmRequestType 0x40, wIndex 0, no data).
enum class FtdiRequest : std::uint8_t {
  Reset = 0,         //!< wValue 1: purge RX, 2: purge TX
  ModemControl = 1,  //!< RTS/DTR
  FlowControl = 2,
  BaudDivisor = 3,
  LineProperties = 4,
  LatencyTimer = 9,
};

class Transport {
 public:
  virtual ~Transport() = default;
  virtual DeviceStatus control(FtdiRequest request, std::uint16_t value) = 0;
  virtual DeviceStatus bulk_write(std::span<const std::uint8_t> data) = 0;
  //! One bulk-IN transfer into \p buffer (it begins with the FTDI's two status bytes);
  //! \p received = 0 on timeout.
  virtual DeviceStatus bulk_read(std::span<std::uint8_t> buffer, std::size_t& received,
                                 int timeout_ms) = 0;
};

}  // namespace touchmend::device::falcon
