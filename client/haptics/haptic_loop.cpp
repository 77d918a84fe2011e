#include "client/haptics/haptic_loop.h"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <ctime>
#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>

namespace touchmend::haptics {
namespace {

thread_local bool t_haptic_thread = false;

std::int64_t monotonic_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return std::int64_t(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

void sleep_until_ns(std::int64_t t) {
  timespec ts{};
  ts.tv_sec = t / 1'000'000'000;
  ts.tv_nsec = t % 1'000'000'000;
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
  }
}

}  // namespace

bool on_haptic_thread() {
  return t_haptic_thread;
}

WorkspaceMap WorkspaceMap::fit(const Eigen::AlignedBox3d& model, const Eigen::AlignedBox3d& device,
                               double margin) {
  WorkspaceMap map;
  if (model.isEmpty() || device.isEmpty()) return map;
  const double model_size = model.diagonal().maxCoeff();
  const double device_size = device.diagonal().minCoeff();
  map.scale = device_size > 0 && model_size > 0 ? margin * model_size / device_size : 1.0;
  map.centre = model.center() - map.scale * device.center();
  return map;
}

void Histogram::add(std::int64_t ns) {
  const std::int64_t us = std::max<std::int64_t>(0, ns / 1000);
  const auto bin = static_cast<std::size_t>(std::min<std::int64_t>(us, kBins));
  bins_[bin].fetch_add(1, std::memory_order_relaxed);
  count_.fetch_add(1, std::memory_order_relaxed);
  std::int64_t m = max_ns_.load(std::memory_order_relaxed);
  while (ns > m && !max_ns_.compare_exchange_weak(m, ns, std::memory_order_relaxed)) {
  }
}

double Histogram::percentile_us(double q) const {
  std::uint64_t total = 0;
  for (const auto& b : bins_) total += b.load(std::memory_order_relaxed);
  if (total == 0) return 0;
  const auto rank = static_cast<std::uint64_t>(std::ceil(q * double(total)));
  std::uint64_t seen = 0;
  for (std::size_t i = 0; i <= kBins; ++i) {
    seen += bins_[i].load(std::memory_order_relaxed);
    if (seen >= std::max<std::uint64_t>(rank, 1)) return i == kBins ? max_us() : double(i + 1);
  }
  return max_us();
}

void Histogram::reset() {
  for (auto& b : bins_) b.store(0, std::memory_order_relaxed);
  count_.store(0, std::memory_order_relaxed);
  max_ns_.store(0, std::memory_order_relaxed);
}

HapticLoop::HapticLoop(device::SafetyFilter& device, ProxyPatchExchange& patches,
                       HapticLoopOptions options)
    : device_(device), patches_(patches), options_(std::move(options)), god_(options_.contact) {
  options_.rate_hz = std::clamp(options_.rate_hz, 100.0, 4000.0);
  // Stiffness and damping within the device's spec (HAPTICS.md §5.3 rule 5).
  const device::Gains g = device::admit_gains(device_.info(), options_.stiffness, options_.damping);
  stiffness_ = g.stiffness;
  damping_ = g.damping;
}

HapticLoop::~HapticLoop() {
  stop();
}

void HapticLoop::start() {
  if (running_.exchange(true)) return;
  thread_ = std::thread([this] { run(); });
  if (options_.realtime) {
    sched_param param{};
    param.sched_priority = options_.fifo_priority;
    const int rc = pthread_setschedparam(thread_.native_handle(), SCHED_FIFO, &param);
    realtime_.store(rc == 0);
    realtime_note_ = rc == 0 ? "SCHED_FIFO priority " + std::to_string(options_.fifo_priority)
                             : std::string("SCHED_FIFO refused: ") + std::strerror(rc);
#if defined(__SANITIZE_ADDRESS__)
    // AddressSanitizer reserves terabytes of shadow memory: locking it all would exhaust RAM.
    if (rc == 0) realtime_note_ += "; memory not locked (AddressSanitizer build)";
#else
    if (rc == 0 && mlockall(MCL_CURRENT | MCL_FUTURE) != 0)
      realtime_note_ += "; mlockall failed: " + std::string(std::strerror(errno));
#endif
  } else {
    realtime_note_ = "normal scheduling (SCHED_FIFO not requested)";
  }
}

void HapticLoop::stop() {
  if (!running_.exchange(false)) return;
  if (thread_.joinable()) thread_.join();
  device_.write({Vec3::Zero(), 0});
}

LoopStats HapticLoop::stats() const {
  LoopStats s;
  s.ticks = ticks_.load(std::memory_order_relaxed);
  s.overruns = overruns_.load(std::memory_order_relaxed);
  s.no_device_state = no_state_.load(std::memory_order_relaxed);
  s.patches_taken = patches_taken_.load(std::memory_order_relaxed);
  s.samples_dropped = samples_dropped_.load(std::memory_order_relaxed);
  s.realtime = realtime_.load();
  s.realtime_note = realtime_note_;
  return s;
}

void HapticLoop::reset_statistics() {
  period_error_.reset();
  compute_time_.reset();
  overruns_.store(0);
}

void HapticLoop::run() {
  t_haptic_thread = true;
  const auto period = static_cast<std::int64_t>(1e9 / options_.rate_hz);
  std::int64_t deadline = monotonic_ns() + period;
  std::int64_t previous_start = 0;
  while (running_.load(std::memory_order_acquire)) {
    // Sleep to just before the deadline, then spin: the scheduler's wake-up latency lands
    // in the sleep, not in the period.
    if (deadline - monotonic_ns() > options_.spin_ns) sleep_until_ns(deadline - options_.spin_ns);
    std::int64_t start = monotonic_ns();
    while (start < deadline) start = monotonic_ns();
    if (previous_start > 0) period_error_.add(std::abs((start - previous_start) - period));
    previous_start = start;
    step(start);
    compute_time_.add(monotonic_ns() - start);
    deadline += period;
    const std::int64_t now = monotonic_ns();
    if (now > deadline + period) {
      // Far behind (a stall): skip the missed ticks instead of bursting through them.
      overruns_.fetch_add(1, std::memory_order_relaxed);
      deadline = now + period;
    }
  }
  t_haptic_thread = false;
}

void HapticLoop::step(std::int64_t now_ns) {
  ++tick_;
  ticks_.store(tick_, std::memory_order_relaxed);
  if (patches_.update()) {
    const ProxyPatch& p = patches_.front();
    if (have_patch_ && p.version != patch_version_) {
      // A remote edit: keep the proxy on the side it was touching, then ease the force in.
      god_.reseat(p.triangles, 0.05 * p.radius);
      if (options_.blend_ticks > 0) {
        blend_left_ = options_.blend_ticks;
        blend_from_ = last_force_;
      }
    }
    have_patch_ = true;
    patch_version_ = p.version;
    patches_taken_.fetch_add(1, std::memory_order_relaxed);
  }
  device::DeviceState state;
  ToolState out;
  out.time_ns = now_ns;
  out.tick = tick_;
  if (!device_.read(state)) {
    no_state_.fetch_add(1, std::memory_order_relaxed);
    device_.write({Vec3::Zero(), 0});
    last_force_.setZero();
    ui_state_.publish(out);
    updater_state_.publish(out);
    return;
  }
  const WorkspaceMap& map = options_.workspace;
  const Vec3 tool = map.to_model(state.position);
  Vec3 goal = tool;
  // A plane fixture: the proxy's goal is the tool projected onto the plane, so the contact
  // spring pulls the device back onto it (and the surface still stops the proxy).
  constraint_.update();
  const PlaneConstraint& plane = constraint_.front();
  if (plane.active) goal -= (goal - plane.point).dot(plane.normal) * plane.normal;
  Vec3 force = Vec3::Zero();
  ContactResult contact;
  const ProxyPatch& patch = patches_.front();
  if (!god_.initialized()) god_.reset(goal);
  if (have_patch_ && (goal - patch.centre).norm() <= patch.radius &&
      (god_.proxy() - patch.centre).norm() <= patch.radius) {
    contact = god_.update(patch.triangles, goal);
    const Vec3 proxy_device = map.to_device(contact.proxy);
    force = stiffness_ * (proxy_device - state.position);
    if (contact.in_contact) force -= damping_ * state.velocity;
  } else if (!have_patch_) {
    god_.reset(goal);  // nothing to touch yet: the proxy follows the tool
    contact.proxy = goal;
  } else {
    // The tool outran its patch (the proxy-update thread is behind): hold the proxy where it
    // was valid and send no force, rather than let it pass through geometry not in the patch.
    contact.proxy = god_.proxy();
  }
  if (blend_left_ > 0) {
    const double u =
        double(options_.blend_ticks - blend_left_ + 1) / double(options_.blend_ticks + 1);
    force = blend_from_ + u * (force - blend_from_);
    --blend_left_;
  }
  device_.write({force, 0});
  last_force_ = device_.last_output();
  out.device_position = tool;
  out.proxy = contact.proxy;
  out.velocity = map.scale * state.velocity;
  out.force = last_force_;
  out.buttons = state.buttons;
  out.in_contact = contact.in_contact;
  out.face_id = contact.face_id;
  out.patch_version = patch_version_;
  out.device_ok = true;
  ui_state_.publish(out);
  updater_state_.publish(out);
  if (!samples_.push({now_ns, contact.proxy, state.buttons, contact.in_contact}))
    samples_dropped_.fetch_add(1, std::memory_order_relaxed);
}

}  // namespace touchmend::haptics
