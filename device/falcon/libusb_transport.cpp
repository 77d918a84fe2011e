#include "device/falcon/libusb_transport.h"

#include <libusb-1.0/libusb.h>

#include <fmt/format.h>

namespace touchmend::device::falcon {
namespace {

constexpr unsigned char kEndpointOut = 0x02;
constexpr unsigned char kEndpointIn = 0x81;
constexpr unsigned int kControlTimeoutMs = 1000;

struct Context {
  libusb_context* ctx = nullptr;
  int status = 0;
  Context() { status = libusb_init(&ctx); }
  ~Context() {
    if (ctx) libusb_exit(ctx);
  }
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;
};

bool is_falcon(libusb_device* device) {
  libusb_device_descriptor d{};
  return libusb_get_device_descriptor(device, &d) == 0 && d.idVendor == kVendorId &&
         d.idProduct == kProductId;
}

}  // namespace

std::string describe_libusb_error(int code) {
  const std::string name = libusb_error_name(code);
  switch (code) {
    case LIBUSB_ERROR_ACCESS:
      return name +
             ": permission denied opening the Falcon. Install a udev rule for 0403:cb48 "
             "(e.g. SUBSYSTEM==\"usb\", ATTRS{idVendor}==\"0403\", ATTRS{idProduct}==\"cb48\", "
             "MODE=\"0666\") or run as a user in the group the rule names";
    case LIBUSB_ERROR_NO_DEVICE:
      return name + ": the Falcon was unplugged";
    case LIBUSB_ERROR_BUSY:
      return name + ": the Falcon is in use by another program (or a kernel driver kept it)";
    case LIBUSB_ERROR_TIMEOUT:
      return name + ": the Falcon did not answer in time";
    case LIBUSB_ERROR_PIPE:
      return name + ": USB endpoint stalled";
    case LIBUSB_ERROR_IO:
      return name + ": USB input/output error (cable, hub or power)";
    default:
      return name;
  }
}

std::vector<UsbDeviceEntry> list_falcons(std::string& error) {
  std::vector<UsbDeviceEntry> out;
  Context context;
  if (context.status != 0) {
    error = "libusb could not initialise: " + describe_libusb_error(context.status);
    return out;
  }
  libusb_device** list = nullptr;
  const ssize_t n = libusb_get_device_list(context.ctx, &list);
  if (n < 0) {
    error = "libusb could not list devices: " + describe_libusb_error(static_cast<int>(n));
    return out;
  }
  for (ssize_t i = 0; i < n; ++i) {
    if (!is_falcon(list[i])) continue;
    out.push_back({static_cast<int>(out.size()), libusb_get_bus_number(list[i]),
                   libusb_get_device_address(list[i])});
  }
  libusb_free_device_list(list, 1);
  return out;
}

LibusbTransport::~LibusbTransport() {
  if (handle_) {
    libusb_release_interface(handle_, 0);
    libusb_close(handle_);
  }
  if (context_) libusb_exit(context_);
}

DeviceStatus LibusbTransport::open(int index, std::unique_ptr<LibusbTransport>& out) {
  std::unique_ptr<LibusbTransport> t(new LibusbTransport());
  if (int rc = libusb_init(&t->context_); rc != 0) {
    t->context_ = nullptr;
    return DeviceStatus::failure("libusb could not initialise: " + describe_libusb_error(rc));
  }
  libusb_device** list = nullptr;
  const ssize_t n = libusb_get_device_list(t->context_, &list);
  if (n < 0)
    return DeviceStatus::failure("libusb could not list devices: " +
                                 describe_libusb_error(static_cast<int>(n)));
  libusb_device* chosen = nullptr;
  int found = 0;
  for (ssize_t i = 0; i < n; ++i) {
    if (!is_falcon(list[i])) continue;
    if (found++ == index) chosen = list[i];
  }
  int rc = LIBUSB_ERROR_NOT_FOUND;
  if (chosen) rc = libusb_open(chosen, &t->handle_);
  libusb_free_device_list(list, 1);
  if (!chosen) {
    return DeviceStatus::failure(
        found == 0 ? "no Novint Falcon found (USB 0403:cb48): is it plugged in and powered?"
                   : fmt::format("no Falcon with index {} ({} found)", index, found));
  }
  if (rc != 0) {
    t->handle_ = nullptr;
    return DeviceStatus::failure("cannot open the Falcon: " + describe_libusb_error(rc));
  }
  libusb_set_auto_detach_kernel_driver(t->handle_, 1);  // harmless when none is bound
  if (rc = libusb_claim_interface(t->handle_, 0); rc != 0)
    return DeviceStatus::failure("cannot claim the Falcon's interface: " +
                                 describe_libusb_error(rc));
  out = std::move(t);
  return {};
}

DeviceStatus LibusbTransport::control(FtdiRequest request, std::uint16_t value) {
  const int rc = libusb_control_transfer(handle_, 0x40, static_cast<std::uint8_t>(request), value,
                                         0, nullptr, 0, kControlTimeoutMs);
  if (rc < 0) return DeviceStatus::failure("USB control transfer: " + describe_libusb_error(rc));
  return {};
}

DeviceStatus LibusbTransport::bulk_write(std::span<const std::uint8_t> data) {
  int sent = 0;
  const int rc = libusb_bulk_transfer(handle_, kEndpointOut, const_cast<std::uint8_t*>(data.data()),
                                      static_cast<int>(data.size()), &sent, kControlTimeoutMs);
  if (rc != 0) return DeviceStatus::failure("USB write: " + describe_libusb_error(rc));
  if (sent != static_cast<int>(data.size()))
    return DeviceStatus::failure(fmt::format("USB write: {} of {} bytes sent", sent, data.size()));
  return {};
}

DeviceStatus LibusbTransport::bulk_read(std::span<std::uint8_t> buffer, std::size_t& received,
                                        int timeout_ms) {
  int got = 0;
  // 64-byte transfers: the FTDI's packet size (larger or smaller requests misbehave on some
  // hosts, HAPTICS.md §2.2); the handshake's larger buffer is read 64 bytes at a time.
  const int length = static_cast<int>(std::min<std::size_t>(buffer.size(), 64));
  const int rc = libusb_bulk_transfer(handle_, kEndpointIn, buffer.data(), length, &got,
                                      static_cast<unsigned int>(timeout_ms));
  received = static_cast<std::size_t>(std::max(got, 0));
  if (rc == LIBUSB_ERROR_TIMEOUT) return {};
  if (rc != 0) return DeviceStatus::failure("USB read: " + describe_libusb_error(rc));
  return {};
}

}  // namespace touchmend::device::falcon
