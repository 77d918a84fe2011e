#pragma once

//! \file trajectory.h
//! \brief Recorded device trajectories: the file format, the replay device and the recorder.
//!
//! \details Format, version 1 (text, one sample per line, `#` starts a comment line):
//!
//!     touchmend-trajectory 1
//!     workspace -0.1 -0.1 -0.1 0.1 0.1 0.1
//!     # t_seconds x y z buttons
//!     0.000000000 0.012 -0.003 0.040 0
//!     0.001000000 0.012 -0.003 0.039 1
//!
//! t is seconds from the first sample (non-decreasing), x y z metres in the device frame,
//! buttons a decimal bit mask. The optional `workspace` line (before the samples) is the
//! recording device's workspace box, min then max corner, so a replay maps onto the model the
//! way the recording did; without it the samples' bounding box is used. A reader rejects other
//! versions, non-finite numbers, time going backwards and more than 50 million samples, naming the
//! line.

#include <filesystem>
#include <string>
#include <vector>

#include "device/haptic_device.h"

namespace touchmend::device {

struct TrajectorySample {
  double t = 0;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  std::uint32_t buttons = 0;
};

inline constexpr int kTrajectoryVersion = 1;
inline constexpr std::size_t kMaxTrajectorySamples = 50'000'000;

struct Trajectory {
  std::vector<TrajectorySample> samples;
  Eigen::AlignedBox3d workspace;  //!< empty when the file has no workspace line
};

DeviceStatus parse_trajectory(const std::string& text, Trajectory& out);
DeviceStatus read_trajectory(const std::filesystem::path& file, Trajectory& out);
std::string format_trajectory(const Trajectory& trajectory);
//! Writes atomically (a temporary file renamed over the target).
DeviceStatus write_trajectory(const std::filesystem::path& file, const Trajectory& trajectory);

struct ReplayOptions {
  bool virtual_clock = false;  //!< advance() moves time; else the steady clock
  bool loop = false;           //!< start over at the end
};

//! Plays a trajectory at its recorded rate. No actuators: forces written are counted (and the
//! last kept) so a test can inspect what the loop commanded.
class ReplayDevice final : public HapticDevice {
 public:
  ReplayDevice(Trajectory trajectory, std::string name, ReplayOptions options = {});
  static DeviceStatus from_file(const std::filesystem::path& file, ReplayOptions options,
                                std::unique_ptr<ReplayDevice>& out);

  DeviceStatus open() override;
  void close() override { open_ = false; }
  const DeviceInfo& info() const override { return info_; }
  bool read(DeviceState& state) override;
  void write(const ForceCommand& command) override;
  std::int64_t now_ns() const override;
  std::string last_error() const override { return {}; }
  void clear_error() override {}

  void advance(std::int64_t ns) { virtual_now_ns_ += ns; }
  //! True once the last sample has been reached (never with loop).
  bool finished() const { return finished_; }
  double duration_seconds() const { return samples_.empty() ? 0 : samples_.back().t; }
  std::uint64_t commands_written() const { return commands_; }
  const ForceCommand& last_command() const { return last_command_; }

 private:
  std::vector<TrajectorySample> samples_;
  ReplayOptions options_;
  DeviceInfo info_;
  bool open_ = false;
  bool finished_ = false;
  std::int64_t virtual_now_ns_ = 0;
  std::int64_t open_ns_ = 0;
  std::size_t index_ = 0;
  std::uint64_t commands_ = 0;
  ForceCommand last_command_;
};

//! Records every new state read through it (for --record FILE). The buffer is reserved up
//! front so the haptic thread never allocates; samples beyond it are counted as dropped.
class RecordingDevice final : public HapticDevice {
 public:
  RecordingDevice(HapticDevice& inner, std::filesystem::path file,
                  std::size_t capacity = 30 * 60 * 1000);

  DeviceStatus open() override { return inner_.open(); }
  //! Closes the device, then writes the file.
  void close() override;
  const DeviceInfo& info() const override { return inner_.info(); }
  bool read(DeviceState& state) override;
  void write(const ForceCommand& command) override { inner_.write(command); }
  std::int64_t now_ns() const override { return inner_.now_ns(); }
  std::string last_error() const override;
  void clear_error() override { inner_.clear_error(); }

  std::size_t recorded() const { return samples_.size(); }
  std::size_t dropped() const { return dropped_; }
  //! Writes what was recorded so far (close() calls it).
  DeviceStatus save();

 private:
  HapticDevice& inner_;
  std::filesystem::path file_;
  std::vector<TrajectorySample> samples_;
  std::size_t capacity_;
  std::size_t dropped_ = 0;
  std::uint64_t last_sequence_ = 0;
  bool have_first_ = false;
  std::int64_t first_ns_ = 0;
  std::string save_error_;
};

}  // namespace touchmend::device
