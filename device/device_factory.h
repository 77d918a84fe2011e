#pragma once

//! \file device_factory.h
//! \brief `--device sim|replay:FILE|falcon[:INDEX]` and `--list-devices`.

#include <memory>
#include <string>
#include <vector>

#include "device/falcon/falcon_device.h"
#include "device/simulated_device.h"
#include "device/trajectory.h"

namespace touchmend::device {

struct DeviceSpec {
  enum class Kind { Simulated, Replay, Falcon } kind = Kind::Simulated;
  std::string file;  //!< replay
  int index = 0;     //!< falcon
};

//! Parses a --device value; the error names what was expected.
DeviceStatus parse_device_spec(const std::string& text, DeviceSpec& out);

struct DeviceOptions {
  SimulatedOptions simulated;
  ReplayOptions replay;
  falcon::FalconOptions falcon;
};

//! Creates (does not open) the device.
DeviceStatus make_device(const DeviceSpec& spec, const DeviceOptions& options,
                         std::unique_ptr<HapticDevice>& out);

struct DeviceListing {
  std::string spec;  //!< what to pass to --device
  std::string description;
};
//! Always the simulated device and the replay device; every Falcon on USB. \p notes gets
//! what could not be probed (libusb failing) — not an error: the other devices still work.
std::vector<DeviceListing> list_devices(std::string& notes);

}  // namespace touchmend::device
