#include "client/haptics/proxy_updater.h"

#include <chrono>

namespace touchmend::haptics {

ProxyUpdater::ProxyUpdater(HapticLoop& loop, ProxyPatchExchange& patches,
                           ProxyUpdaterOptions options)
    : loop_(loop), patches_(patches), options_(options) {}

ProxyUpdater::~ProxyUpdater() {
  stop();
}

void ProxyUpdater::set_surface(std::shared_ptr<const SurfaceMesh> surface) {
  {
    std::lock_guard lock(mutex_);
    pending_ = std::move(surface);
  }
  wake_.notify_one();
}

void ProxyUpdater::index_pending() {
  std::shared_ptr<const SurfaceMesh> fresh;
  {
    std::lock_guard lock(mutex_);
    fresh = std::move(pending_);
    pending_.reset();
  }
  if (fresh) index_surface(std::move(fresh));
}

void ProxyUpdater::start() {
  if (running_.exchange(true)) return;
  thread_ = std::thread([this] { run(); });
}

void ProxyUpdater::stop() {
  if (!running_.exchange(false)) return;
  wake_.notify_one();
  if (thread_.joinable()) thread_.join();
}

void ProxyUpdater::index_surface(std::shared_ptr<const SurfaceMesh> surface) {
  whole_.build(*surface);
  version_ = surface->version;
  if (options_.radius > 0) {
    radius_ = options_.radius;
  } else {
    radius_ = whole_.empty() ? 1.0 : 0.08 * whole_.bounds().diagonal().norm();
  }
  have_surface_ = true;
  have_patch_ = false;  // the next round cuts a patch of the new version
}

void ProxyUpdater::build_patch(const Vec3& centre, double extra) {
  const auto start = std::chrono::steady_clock::now();
  whole_.in_sphere(centre, radius_ + extra, scratch_);
  ProxyPatch& patch = patches_.back();
  patch.version = version_;
  patch.centre = centre;
  patch.radius = radius_ + extra;
  patch.triangles.build_from(whole_, scratch_);
  patches_.publish();
  patch_centre_ = centre;
  patch_extra_ = extra;
  have_patch_ = true;
  built_.fetch_add(1);
  last_patch_size_.store(scratch_.size());
  last_build_ms_.store(
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
}

void ProxyUpdater::run() {
  while (running_.load()) {
    std::shared_ptr<const SurfaceMesh> fresh;
    {
      std::unique_lock lock(mutex_);
      wake_.wait_for(lock, std::chrono::milliseconds(options_.poll_ms),
                     [&] { return pending_ != nullptr || !running_.load(); });
      fresh = std::move(pending_);
      pending_.reset();
    }
    if (!running_.load()) break;
    if (fresh) index_surface(std::move(fresh));
    if (!have_surface_) continue;
    auto& states = loop_.updater_state();
    states.update();
    const ToolState& tool = states.front();
    // The patch must hold both the proxy and the device position (the haptic loop holds the
    // proxy still while either is outside it), so it is centred between them, ahead of the
    // motion, and grown by half their distance plus the look-ahead.
    const Vec3 proxy = tool.device_ok ? tool.proxy : patch_centre_;
    const Vec3 device = tool.device_ok ? tool.device_position : patch_centre_;
    const Vec3 between = 0.5 * (proxy + device);
    const Vec3 shift = options_.look_ahead_seconds * tool.velocity;
    // The margin used up is measured against the grown radius, or a steady stroke would
    // rebuild at every poll.
    const double slack = radius_ / 3 + patch_extra_;
    const bool moved =
        (proxy - patch_centre_).norm() > slack || (device - patch_centre_).norm() > slack;
    if (!have_patch_ || moved) {
      const Vec3 centre = shift.allFinite() ? Vec3(between + shift) : between;
      const double extra =
          std::min(0.5 * (proxy - device).norm() + (centre - between).norm(), 4 * radius_);
      build_patch(centre.allFinite() ? centre : proxy, extra);
    }
  }
}

}  // namespace touchmend::haptics
