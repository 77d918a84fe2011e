#pragma once

//! \file libusb_transport.h
//! \brief The Falcon's FTDI chip over libusb-1.0: enumeration of 0403:cb48, interface 0,
//! bulk OUT 0x02 / IN 0x81 (64-byte reads), vendor control transfers. libusb error codes
//! become messages a user can act on (unplugged, permissions, busy).

#include <memory>
#include <string>
#include <vector>

#include "device/falcon/falcon_transport.h"

struct libusb_context;
struct libusb_device_handle;

namespace touchmend::device::falcon {

inline constexpr std::uint16_t kVendorId = 0x0403;
inline constexpr std::uint16_t kProductId = 0xCB48;

struct UsbDeviceEntry {
  int index = 0;
  int bus = 0;
  int address = 0;
};

//! The Falcons on the USB buses (empty when none; \p error set when libusb itself fails).
std::vector<UsbDeviceEntry> list_falcons(std::string& error);

//! A message for a libusb error code, with the fix where there is one.
std::string describe_libusb_error(int code);

class LibusbTransport final : public Transport {
 public:
  ~LibusbTransport() override;
  //! Opens the \p index-th Falcon and claims interface 0.
  static DeviceStatus open(int index, std::unique_ptr<LibusbTransport>& out);

  DeviceStatus control(FtdiRequest request, std::uint16_t value) override;
  DeviceStatus bulk_write(std::span<const std::uint8_t> data) override;
  DeviceStatus bulk_read(std::span<std::uint8_t> buffer, std::size_t& received,
                         int timeout_ms) override;

 private:
  LibusbTransport() = default;
  libusb_context* context_ = nullptr;
  libusb_device_handle* handle_ = nullptr;
};

}  // namespace touchmend::device::falcon
