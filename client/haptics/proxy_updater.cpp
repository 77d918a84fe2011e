#include "client/haptics/proxy_updater.h"

#include <chrono>

namespace touchmend::haptics {

ProxyUpdater::ProxyUpdater(HapticLoop& loop, ProxyPatchExchange& patches,
                           ProxyUpdaterOptions options)
    : loop_(loop), patches_(patches), options_(options) {}

ProxyUpdater::~ProxyUpdater() { stop(); }

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
  patch.serial = ++serial_;
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
    const Vec3 at = tool.device_ok ? tool.proxy : patch_centre_;
    const Vec3 ahead = at + options_.look_ahead_seconds * tool.velocity;
    // A patch around the predicted position, rebuilt once the tool has used up a third of the
    // margin. The patch must contain both the proxy and the device position (the haptic loop
    // holds the proxy still when either leaves it).
    // (The patch is centred ahead of the motion and grown by that look-ahead: measure the
    // margin used up against the grown radius, or a steady stroke would rebuild every poll.)
    const double slack = radius_ / 3 + patch_extra_;
    const bool moved = (at - patch_centre_).norm() > slack ||
                       (tool.device_position - patch_centre_).norm() > slack;
    if (!have_patch_ || moved) {
      // Centred ahead of the motion, grown so the current position stays well inside.
      if (ahead.allFinite())
        build_patch(ahead, (ahead - at).norm());
      else
        build_patch(at);
    }
  }
}

}  // namespace touchmend::haptics
