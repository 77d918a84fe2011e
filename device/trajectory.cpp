#include "device/trajectory.h"

#include <charconv>
#include <cmath>
#include <fstream>
#include <memory>
#include <sstream>
#include <unistd.h>

#include <fmt/format.h>

namespace touchmend::device {
namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t' || s.front() == '\r'))
    s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r'))
    s.remove_suffix(1);
  return s;
}

bool next_field(std::string_view& s, std::string_view& field) {
  s = trim(s);
  if (s.empty()) return false;
  const auto end = s.find_first_of(" \t");
  field = s.substr(0, end);
  s = end == std::string_view::npos ? std::string_view{} : s.substr(end);
  return true;
}

template <class T>
bool parse_number(std::string_view field, T& value) {
  const auto [ptr, ec] = std::from_chars(field.data(), field.data() + field.size(), value);
  return ec == std::errc() && ptr == field.data() + field.size();
}

}  // namespace

DeviceStatus parse_trajectory(const std::string& text, Trajectory& trajectory) {
  std::vector<TrajectorySample>& out = trajectory.samples;
  out.clear();
  trajectory.workspace.setEmpty();
  std::size_t line_number = 0;
  bool have_header = false;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t end = std::min(text.find('\n', start), text.size());
    const std::string_view line = trim(std::string_view(text).substr(start, end - start));
    start = end + 1;
    ++line_number;
    if (line.empty() || line.front() == '#') {
      if (end == text.size()) break;
      continue;
    }
    auto fail = [&](const std::string& why) {
      return DeviceStatus::failure(fmt::format("trajectory line {}: {}", line_number, why));
    };
    if (!have_header) {
      std::string_view rest = line, magic, version;
      int v = 0;
      if (!next_field(rest, magic) || magic != "touchmend-trajectory" ||
          !next_field(rest, version) || !parse_number(version, v)) {
        return fail("not a touchmend trajectory (expected the header 'touchmend-trajectory 1')");
      }
      if (v != kTrajectoryVersion)
        return fail(fmt::format("format version {} is not supported (this build reads {})", v,
                                kTrajectoryVersion));
      have_header = true;
      if (end == text.size()) break;
      continue;
    }
    std::string_view rest = line, f;
    if (line.rfind("workspace", 0) == 0) {
      if (!out.empty()) return fail("the workspace line must come before the samples");
      next_field(rest, f);
      double box[6];
      for (double& value : box) {
        if (!next_field(rest, f) || !parse_number(f, value) || !std::isfinite(value))
          return fail("expected 'workspace minx miny minz maxx maxy maxz'");
      }
      trajectory.workspace = Eigen::AlignedBox3d(Eigen::Vector3d(box[0], box[1], box[2]),
                                                 Eigen::Vector3d(box[3], box[4], box[5]));
      if (trajectory.workspace.isEmpty()) return fail("the workspace box is empty");
      if (end == text.size()) break;
      continue;
    }
    TrajectorySample s;
    double values[4];
    for (double& value : values) {
      if (!next_field(rest, f)) return fail("expected 't x y z buttons'");
      if (!parse_number(f, value) || !std::isfinite(value))
        return fail(fmt::format("'{}' is not a finite number", f));
    }
    if (!next_field(rest, f) || !parse_number(f, s.buttons))
      return fail("expected the buttons as a non-negative integer");
    if (next_field(rest, f)) return fail("too many fields (expected 't x y z buttons')");
    s.t = values[0];
    s.position = Eigen::Vector3d(values[1], values[2], values[3]);
    if (s.t < 0 || (!out.empty() && s.t < out.back().t)) return fail("time goes backwards");
    if (out.size() >= kMaxTrajectorySamples)
      return fail(fmt::format("more than {} samples", kMaxTrajectorySamples));
    out.push_back(s);
    if (end == text.size()) break;
  }
  if (!have_header) return DeviceStatus::failure("trajectory: empty file (no header)");
  if (out.empty()) return DeviceStatus::failure("trajectory: no samples");
  return {};
}

DeviceStatus read_trajectory(const std::filesystem::path& file, Trajectory& out) {
  std::ifstream in(file, std::ios::binary);
  if (!in) return DeviceStatus::failure("cannot open trajectory " + file.string());
  std::error_code ec;
  const auto size = std::filesystem::file_size(file, ec);
  if (!ec && size > 4ull << 30) return DeviceStatus::failure(file.string() + ": larger than 4 GiB");
  std::ostringstream buffer;
  buffer << in.rdbuf();
  DeviceStatus s = parse_trajectory(buffer.str(), out);
  if (!s.ok) s.message = file.string() + ": " + s.message;
  return s;
}

std::string format_trajectory(const Trajectory& trajectory) {
  std::string out = fmt::format("touchmend-trajectory {}\n", kTrajectoryVersion);
  if (!trajectory.workspace.isEmpty()) {
    const auto& a = trajectory.workspace.min();
    const auto& b = trajectory.workspace.max();
    out += fmt::format("workspace {} {} {} {} {} {}\n", a.x(), a.y(), a.z(), b.x(), b.y(), b.z());
  }
  out += "# t_seconds x y z buttons (metres)\n";
  for (const auto& s : trajectory.samples) {
    // Shortest round-trip formatting: a replayed file reproduces the recorded doubles.
    out += fmt::format("{:.9f} {} {} {} {}\n", s.t, s.position.x(), s.position.y(), s.position.z(),
                       s.buttons);
  }
  return out;
}

DeviceStatus write_trajectory(const std::filesystem::path& file, const Trajectory& trajectory) {
  const std::filesystem::path temp = file.string() + ".tmp-" + std::to_string(::getpid());
  {
    std::ofstream out(temp, std::ios::binary | std::ios::trunc);
    if (!out) return DeviceStatus::failure("cannot write " + temp.string());
    out << format_trajectory(trajectory);
    out.flush();
    if (!out) {
      std::error_code ec;
      std::filesystem::remove(temp, ec);
      return DeviceStatus::failure("writing " + temp.string() + " failed");
    }
  }
  std::error_code ec;
  std::filesystem::rename(temp, file, ec);
  if (ec) {
    std::filesystem::remove(temp, ec);
    return DeviceStatus::failure("cannot rename onto " + file.string() + ": " + ec.message());
  }
  return {};
}

// ---------------------------------------------------------------------------------------

ReplayDevice::ReplayDevice(Trajectory trajectory, std::string name, ReplayOptions options)
    : samples_(std::move(trajectory.samples)), options_(options) {
  info_.kind = "replay";
  info_.name = "replay of " + name;
  info_.force_dof = 0;
  info_.max_force = 5.0;
  info_.max_stiffness = 2000;
  info_.max_damping = 10;
  info_.buttons = 2;
  if (!trajectory.workspace.isEmpty()) {
    info_.workspace = trajectory.workspace;
  } else if (!samples_.empty()) {
    Eigen::AlignedBox3d box;
    for (const auto& s : samples_) box.extend(s.position);
    info_.workspace = box;
  }
}

DeviceStatus ReplayDevice::from_file(const std::filesystem::path& file, ReplayOptions options,
                                     std::unique_ptr<ReplayDevice>& out) {
  Trajectory trajectory;
  if (DeviceStatus s = read_trajectory(file, trajectory); !s.ok) return s;
  out = std::make_unique<ReplayDevice>(std::move(trajectory), file.filename().string(), options);
  return {};
}

std::int64_t ReplayDevice::now_ns() const {
  return options_.virtual_clock ? virtual_now_ns_ : steady_now_ns();
}

DeviceStatus ReplayDevice::open() {
  if (samples_.empty()) return DeviceStatus::failure("the trajectory has no samples");
  open_ = true;
  finished_ = false;
  index_ = 0;
  open_ns_ = now_ns();
  return {};
}

bool ReplayDevice::read(DeviceState& state) {
  if (!open_) return false;
  const std::int64_t now = now_ns();
  double t = double(now - open_ns_) * 1e-9;
  const double duration = samples_.back().t;
  if (options_.loop && duration > 0 && t > duration) {
    const double loops = std::floor(t / duration);
    open_ns_ += static_cast<std::int64_t>(loops * duration * 1e9);
    t -= loops * duration;
    index_ = 0;
  }
  while (index_ + 1 < samples_.size() && samples_[index_ + 1].t <= t) ++index_;
  if (!options_.loop && index_ + 1 == samples_.size()) finished_ = true;
  const TrajectorySample& s = samples_[index_];
  state.timestamp_ns = now;  // the replay is the device: its newest sample is current
  state.sequence = index_ + 1;
  state.position = s.position;
  state.velocity.setZero();
  if (index_ > 0) {
    const TrajectorySample& p = samples_[index_ - 1];
    if (s.t > p.t) state.velocity = (s.position - p.position) / (s.t - p.t);
  }
  state.buttons = s.buttons;
  state.homed = true;
  state.faulted = false;
  return true;
}

void ReplayDevice::write(const ForceCommand& command) {
  ++commands_;
  last_command_ = command;
}

// ---------------------------------------------------------------------------------------

RecordingDevice::RecordingDevice(HapticDevice& inner, std::filesystem::path file,
                                 std::size_t capacity)
    : inner_(inner), file_(std::move(file)), capacity_(capacity) {
  samples_.reserve(capacity_);
}

bool RecordingDevice::read(DeviceState& state) {
  if (!inner_.read(state)) return false;
  if (have_first_ && state.sequence == last_sequence_) return true;
  if (!have_first_) {
    have_first_ = true;
    first_ns_ = state.timestamp_ns;
  }
  last_sequence_ = state.sequence;
  if (samples_.size() < capacity_) {
    samples_.push_back(
        {double(state.timestamp_ns - first_ns_) * 1e-9, state.position, state.buttons});
  } else {
    ++dropped_;
  }
  return true;
}

std::string RecordingDevice::last_error() const {
  std::string e = inner_.last_error();
  return e.empty() ? save_error_ : e;
}

DeviceStatus RecordingDevice::save() {
  if (samples_.empty()) return DeviceStatus::failure("nothing was recorded");
  DeviceStatus s = write_trajectory(file_, Trajectory{samples_, inner_.info().workspace});
  if (!s.ok) save_error_ = s.message;
  return s;
}

void RecordingDevice::close() {
  inner_.close();
  if (!samples_.empty()) (void)save();
}

}  // namespace touchmend::device
