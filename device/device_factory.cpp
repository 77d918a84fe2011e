#include "device/device_factory.h"

#include <charconv>

#include <fmt/format.h>

#include "device/falcon/libusb_transport.h"

namespace touchmend::device {

DeviceStatus parse_device_spec(const std::string& text, DeviceSpec& out) {
  out = {};
  if (text == "sim" || text == "simulated") {
    out.kind = DeviceSpec::Kind::Simulated;
    return {};
  }
  if (text.rfind("replay:", 0) == 0) {
    out.kind = DeviceSpec::Kind::Replay;
    out.file = text.substr(7);
    if (out.file.empty()) return DeviceStatus::failure("replay needs a file: --device replay:FILE");
    return {};
  }
  if (text == "falcon" || text.rfind("falcon:", 0) == 0) {
    out.kind = DeviceSpec::Kind::Falcon;
    if (text.size() > 7) {
      const std::string n = text.substr(7);
      const auto [ptr, ec] = std::from_chars(n.data(), n.data() + n.size(), out.index);
      if (ec != std::errc() || ptr != n.data() + n.size() || out.index < 0)
        return DeviceStatus::failure("falcon index must be a non-negative integer: falcon:0");
    }
    return {};
  }
  return DeviceStatus::failure("unknown device '" + text +
                               "' (expected sim, replay:FILE or falcon[:INDEX])");
}

DeviceStatus make_device(const DeviceSpec& spec, const DeviceOptions& options,
                         std::unique_ptr<HapticDevice>& out) {
  switch (spec.kind) {
    case DeviceSpec::Kind::Simulated:
      out = std::make_unique<SimulatedDevice>(options.simulated);
      return {};
    case DeviceSpec::Kind::Replay: {
      std::unique_ptr<ReplayDevice> replay;
      if (DeviceStatus s = ReplayDevice::from_file(spec.file, options.replay, replay); !s.ok)
        return s;
      out = std::move(replay);
      return {};
    }
    case DeviceSpec::Kind::Falcon: {
      falcon::FalconOptions f = options.falcon;
      f.index = spec.index;
      out = std::make_unique<falcon::FalconDevice>(f);
      return {};
    }
  }
  return DeviceStatus::failure("unknown device kind");
}

std::vector<DeviceListing> list_devices(std::string& notes) {
  std::vector<DeviceListing> out;
  out.push_back({"sim", "simulated stylus (mouse and keyboard in the viewer, or a script)"});
  out.push_back({"replay:FILE", "plays a recorded trajectory (record one with --record FILE)"});
  std::string error;
  const auto falcons = falcon::list_falcons(error);
  if (!error.empty()) notes = error;
  for (const auto& f : falcons)
    out.push_back({fmt::format("falcon:{}", f.index),
                   fmt::format("Novint Falcon on USB bus {} address {}", f.bus, f.address)});
  if (falcons.empty() && error.empty()) notes = "no Novint Falcon on USB (0403:cb48)";
  return out;
}

}  // namespace touchmend::device
