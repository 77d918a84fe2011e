#pragma once

//! \file haptic_loop.h
//! \brief The haptic thread: at 1 kHz (up to 4 kHz) it reads the device, runs the god-object
//! contact on the newest proxy patch, and writes the force through the safety filter.
//!
//! \details Timing: absolute deadlines on the monotonic clock; the thread sleeps
//! (clock_nanosleep) until shortly before each deadline and spins the rest, which is how
//! the period error gets below the scheduler's wake-up latency. It can run with SCHED_FIFO and
//! locked memory when permitted (`realtime`). In the loop it never allocates, locks, logs or
//! does I/O: patches arrive through a triple buffer (ProxyPatchExchange), the tool state leaves
//! through triple buffers and tool samples through a fixed-size single-producer queue, and
//! its statistics are fixed-bin histograms of relaxed atomics.
//!
//! Remote edits: when a patch of a new mesh version arrives the force eases from its old
//! value to the new one over `blend_ticks` ticks (VRPN's recovery cycles) instead of jumping.

#include <array>
#include <atomic>
#include <thread>

#include "client/haptics/god_object.h"
#include "device/safety_filter.h"
#include "device/triple_buffer.h"

namespace touchmend::haptics {

//! Device space (metres) ↔ model space: model = centre + scale · device.
struct WorkspaceMap {
  Vec3 centre = Vec3::Zero();
  double scale = 1.0;
  Vec3 to_model(const Vec3& device) const { return centre + scale * device; }
  Vec3 to_device(const Vec3& model) const { return (model - centre) / scale; }
  //! Fits a model box into a device workspace box (uniform scale, centred).
  static WorkspaceMap fit(const Eigen::AlignedBox3d& model, const Eigen::AlignedBox3d& device,
                          double margin = 1.1);
};

//! A proxy patch with the mesh version it was cut from.
struct ProxyPatch {
  std::uint64_t version = 0;
  Vec3 centre = Vec3::Zero();
  double radius = 0;
  TriangleSet triangles;
};
using ProxyPatchExchange = device::TripleBuffer<ProxyPatch>;

//! What the haptic thread publishes each tick.
struct ToolState {
  std::int64_t time_ns = 0;
  std::uint64_t tick = 0;
  Vec3 device_position = Vec3::Zero();  //!< model space
  Vec3 proxy = Vec3::Zero();            //!< model space
  Vec3 velocity = Vec3::Zero();         //!< model units per second
  Vec3 force = Vec3::Zero();            //!< N, device frame (after the safety filter)
  std::uint32_t buttons = 0;
  bool in_contact = false;
  std::uint32_t face_id = 0;
  std::uint64_t patch_version = 0;
  bool device_ok = false;
};

//! A fixed-capacity single-producer/single-consumer queue (no allocation after construction).
template <class T, std::size_t Capacity>
class SpscQueue {
 public:
  bool push(const T& value) {
    const std::size_t head = head_.load(std::memory_order_relaxed);
    const std::size_t next = (head + 1) % Capacity;
    if (next == tail_.load(std::memory_order_acquire)) return false;  // full: drop
    slots_[head] = value;
    head_.store(next, std::memory_order_release);
    return true;
  }
  bool pop(T& value) {
    const std::size_t tail = tail_.load(std::memory_order_relaxed);
    if (tail == head_.load(std::memory_order_acquire)) return false;
    value = slots_[tail];
    tail_.store((tail + 1) % Capacity, std::memory_order_release);
    return true;
  }

 private:
  std::array<T, Capacity> slots_{};
  std::atomic<std::size_t> head_{0};
  std::atomic<std::size_t> tail_{0};
};

struct ToolSampleOut {
  std::int64_t time_ns = 0;
  Vec3 proxy = Vec3::Zero();  //!< model space
  std::uint32_t buttons = 0;
  bool in_contact = false;
};
using ToolSampleQueue = SpscQueue<ToolSampleOut, 8192>;

//! Microsecond histogram readable from any thread while the haptic thread fills it.
class Histogram {
 public:
  static constexpr std::size_t kBins = 10'000;  // 1 µs bins up to 10 ms, then overflow
  void add(std::int64_t ns);
  //! Percentile in microseconds (bin upper edge), from a consistent-enough snapshot.
  double percentile_us(double q) const;
  double max_us() const { return double(max_ns_.load(std::memory_order_relaxed)) / 1000.0; }
  std::uint64_t count() const { return count_.load(std::memory_order_relaxed); }
  void reset();

 private:
  std::array<std::atomic<std::uint32_t>, kBins + 1> bins_{};
  std::atomic<std::uint64_t> count_{0};
  std::atomic<std::int64_t> max_ns_{0};
};

struct HapticLoopOptions {
  double rate_hz = 1000;   //!< 100-4000
  double stiffness = 800;  //!< N/m in device space (capped by the device's spec)
  double damping = 2;      //!< N·s/m, applied in contact
  ContactOptions contact;
  WorkspaceMap workspace;
  int blend_ticks = 10;
  std::int64_t spin_ns = 80'000;  //!< busy-wait this long before each deadline
  bool realtime = false;          //!< try SCHED_FIFO + mlockall
  int fifo_priority = 80;
};

//! A virtual fixture: the tool is held to a plane (model frame) by the contact spring, as the
//! thesis holds the tool to the guiding surface during push-down against hand shake (seed 000
//! §4.2.3). Set from any thread; the haptic thread takes the newest one each tick.
struct PlaneConstraint {
  bool active = false;
  Vec3 point = Vec3::Zero();
  Vec3 normal = Vec3::UnitZ();  //!< unit
};

struct LoopStats {
  std::uint64_t ticks = 0;
  std::uint64_t overruns = 0;  //!< deadlines missed by more than a period
  std::uint64_t no_device_state = 0;
  std::uint64_t patches_taken = 0;
  std::uint64_t samples_dropped = 0;
  bool realtime = false;  //!< SCHED_FIFO granted
  std::string realtime_note;
};

class HapticLoop {
 public:
  //! \p device is used from the haptic thread only once start() returns.
  HapticLoop(device::SafetyFilter& device, ProxyPatchExchange& patches, HapticLoopOptions options);
  ~HapticLoop();
  HapticLoop(const HapticLoop&) = delete;
  HapticLoop& operator=(const HapticLoop&) = delete;

  void start();
  void stop();
  bool running() const { return running_.load(std::memory_order_acquire); }

  //! Tool state for the UI thread and for the proxy-update thread (one consumer each).
  device::TripleBuffer<ToolState>& ui_state() { return ui_state_; }
  device::TripleBuffer<ToolState>& updater_state() { return updater_state_; }
  ToolSampleQueue& samples() { return samples_; }

  const Histogram& period_error() const { return period_error_; }
  const Histogram& compute_time() const { return compute_time_; }
  LoopStats stats() const;
  void reset_statistics();

  //! One tick's work without the timing (tests drive the loop with virtual clocks).
  void step(std::int64_t now_ns);

  //! Holds the tool to a plane (or releases it: active = false). One producer thread.
  void set_constraint(const PlaneConstraint& constraint) { constraint_.publish(constraint); }

 private:
  void run();

  device::SafetyFilter& device_;
  ProxyPatchExchange& patches_;
  HapticLoopOptions options_;
  double stiffness_ = 0;
  double damping_ = 0;
  GodObject god_;
  std::thread thread_;
  std::atomic<bool> running_{false};
  device::TripleBuffer<ToolState> ui_state_;
  device::TripleBuffer<ToolState> updater_state_;
  ToolSampleQueue samples_;
  device::TripleBuffer<PlaneConstraint> constraint_{PlaneConstraint{}};
  Histogram period_error_;
  Histogram compute_time_;
  // Haptic-thread state.
  std::uint64_t tick_ = 0;
  bool have_patch_ = false;
  std::uint64_t patch_version_ = 0;
  int blend_left_ = 0;
  Vec3 blend_from_ = Vec3::Zero();
  Vec3 last_force_ = Vec3::Zero();
  std::atomic<std::uint64_t> ticks_{0}, overruns_{0}, no_state_{0}, patches_taken_{0},
      samples_dropped_{0};
  std::atomic<bool> realtime_{false};
  std::string realtime_note_;
};

//! True on the haptic thread (for allocation probes in tests and benchmarks).
bool on_haptic_thread();

}  // namespace touchmend::haptics
