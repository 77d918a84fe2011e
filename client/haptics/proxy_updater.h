#pragma once

//! \file proxy_updater.h
//! \brief The proxy-update thread: keeps the haptic thread's local patch current
//! (HAPTICS.md §6.1). It indexes the client's copy of the mesh once per version, and cuts a
//! new patch — the triangles within `radius` of the tool's position plus its motion times
//! `look_ahead_seconds` — whenever the mesh changed or the tool moved a third of the radius
//! away from the patch centre. Patches go to the haptic thread through a triple buffer.

#include <condition_variable>
#include <memory>
#include <mutex>
#include <thread>

#include "client/haptics/haptic_loop.h"

namespace touchmend::haptics {

struct ProxyUpdaterOptions {
  double radius = 0;  //!< model units; 0 = 8% of the mesh's bounding diagonal
  double look_ahead_seconds = 0.1;
  int poll_ms = 2;
};

class ProxyUpdater {
 public:
  ProxyUpdater(HapticLoop& loop, ProxyPatchExchange& patches, ProxyUpdaterOptions options = {});
  ~ProxyUpdater();

  //! A new mesh (any thread): indexed on the updater thread, then a fresh patch.
  void set_surface(std::shared_ptr<const SurfaceMesh> surface);
  void start();
  void stop();

  std::uint64_t patches_built() const { return built_.load(); }
  double last_build_ms() const { return last_build_ms_.load(); }
  std::size_t last_patch_triangles() const { return last_patch_size_.load(); }
  //! Builds one patch now: the triangles within radius() + \p extra of \p centre (also used by
  //! tests without the thread; then call only after set_surface() has been indexed).
  void build_patch(const Vec3& centre, double extra = 0);
  //! Indexes the pending surface now (tests without the thread).
  void index_pending();
  double radius() const { return radius_; }

 private:
  void run();
  void index_surface(std::shared_ptr<const SurfaceMesh> surface);

  HapticLoop& loop_;
  ProxyPatchExchange& patches_;
  ProxyUpdaterOptions options_;
  std::mutex mutex_;
  std::condition_variable wake_;
  std::shared_ptr<const SurfaceMesh> pending_;
  std::thread thread_;
  std::atomic<bool> running_{false};
  // Updater-thread state.
  TriangleSet whole_;
  std::uint64_t version_ = 0;
  double radius_ = 0;
  bool have_surface_ = false;
  bool have_patch_ = false;
  Vec3 patch_centre_ = Vec3::Zero();
  double patch_extra_ = 0;
  std::vector<std::uint32_t> scratch_;
  std::atomic<std::uint64_t> built_{0};
  std::atomic<double> last_build_ms_{0};
  std::atomic<std::size_t> last_patch_size_{0};
};

}  // namespace touchmend::haptics
