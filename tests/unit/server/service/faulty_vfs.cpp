#include "tests/unit/server/service/faulty_vfs.h"

#include <cerrno>
#include <cstring>
#include <sqlite3.h>
#include <stdexcept>

namespace touchmend::testing {
namespace {

// The file of the faulty VFS: its methods, then the real file of the VFS below, in the space
// szOsFile gives (the real file right after this header).
struct FaultyFile {
  sqlite3_file base;
  sqlite3_file* real;
  const char* name;  // valid until xClose (sqlite3_vfs.xOpen's contract); null for temp files
  FaultyVfs* owner;
};
static_assert(sizeof(FaultyFile) % 8 == 0);

// One faulty VFS at a time (the default while it lives).
sqlite3_vfs* g_below = nullptr;

sqlite3_file* real(sqlite3_file* file) {
  return reinterpret_cast<FaultyFile*>(file)->real;
}
const sqlite3_io_methods& below(sqlite3_file* file) {
  return *real(file)->pMethods;
}

int x_close(sqlite3_file* file) {
  return below(file).xClose(real(file));
}
int x_read(sqlite3_file* file, void* buffer, int amount, sqlite3_int64 offset) {
  return below(file).xRead(real(file), buffer, amount, offset);
}
int x_write(sqlite3_file* file, const void* buffer, int amount, sqlite3_int64 offset) {
  auto* f = reinterpret_cast<FaultyFile*>(file);
  if (f->owner->write_fails(f->name)) {
    errno = ENOSPC;
    return SQLITE_FULL;
  }
  return below(file).xWrite(real(file), buffer, amount, offset);
}
int x_truncate(sqlite3_file* file, sqlite3_int64 size) {
  return below(file).xTruncate(real(file), size);
}
int x_sync(sqlite3_file* file, int flags) {
  auto* f = reinterpret_cast<FaultyFile*>(file);
  if (f->owner->sync_fails(f->name)) {
    errno = EIO;
    return SQLITE_IOERR_FSYNC;
  }
  return below(file).xSync(real(file), flags);
}
int x_file_size(sqlite3_file* file, sqlite3_int64* size) {
  return below(file).xFileSize(real(file), size);
}
int x_lock(sqlite3_file* file, int level) {
  return below(file).xLock(real(file), level);
}
int x_unlock(sqlite3_file* file, int level) {
  return below(file).xUnlock(real(file), level);
}
int x_check_reserved_lock(sqlite3_file* file, int* out) {
  return below(file).xCheckReservedLock(real(file), out);
}
int x_file_control(sqlite3_file* file, int op, void* arg) {
  return below(file).xFileControl(real(file), op, arg);
}
int x_sector_size(sqlite3_file* file) {
  return below(file).xSectorSize(real(file));
}
int x_device_characteristics(sqlite3_file* file) {
  return below(file).xDeviceCharacteristics(real(file));
}
int x_shm_map(sqlite3_file* file, int page, int page_size, int extend, void volatile** out) {
  return below(file).xShmMap(real(file), page, page_size, extend, out);
}
int x_shm_lock(sqlite3_file* file, int offset, int n, int flags) {
  return below(file).xShmLock(real(file), offset, n, flags);
}
void x_shm_barrier(sqlite3_file* file) {
  below(file).xShmBarrier(real(file));
}
int x_shm_unmap(sqlite3_file* file, int delete_flag) {
  return below(file).xShmUnmap(real(file), delete_flag);
}
int x_fetch(sqlite3_file* file, sqlite3_int64 offset, int amount, void** out) {
  return below(file).xFetch(real(file), offset, amount, out);
}
int x_unfetch(sqlite3_file* file, sqlite3_int64 offset, void* page) {
  return below(file).xUnfetch(real(file), offset, page);
}

const sqlite3_io_methods kMethods = {
    3,
    x_close,
    x_read,
    x_write,
    x_truncate,
    x_sync,
    x_file_size,
    x_lock,
    x_unlock,
    x_check_reserved_lock,
    x_file_control,
    x_sector_size,
    x_device_characteristics,
    x_shm_map,
    x_shm_lock,
    x_shm_barrier,
    x_shm_unmap,
    x_fetch,
    x_unfetch,
};

int x_open(sqlite3_vfs* vfs, const char* name, sqlite3_file* file, int flags, int* out_flags) {
  auto* f = reinterpret_cast<FaultyFile*>(file);
  f->base.pMethods = nullptr;
  f->real = reinterpret_cast<sqlite3_file*>(f + 1);
  f->name = name;
  f->owner = static_cast<FaultyVfs*>(vfs->pAppData);
  const int rc = g_below->xOpen(g_below, name, f->real, flags, out_flags);
  // The methods only once the real file has its own: SQLite closes a file whose open failed
  // only when pMethods is set.
  if (f->real->pMethods != nullptr) {
    if (f->real->pMethods->iVersion < 3) {  // the forwarding above needs every method
      f->real->pMethods->xClose(f->real);
      return SQLITE_CANTOPEN;
    }
    f->base.pMethods = &kMethods;
  }
  return rc;
}

// The VFS's other calls go to the VFS below as they are (the unix VFS's ignore their vfs).
int x_delete(sqlite3_vfs*, const char* name, int sync_dir) {
  return g_below->xDelete(g_below, name, sync_dir);
}
int x_access(sqlite3_vfs*, const char* name, int flags, int* out) {
  return g_below->xAccess(g_below, name, flags, out);
}
int x_full_pathname(sqlite3_vfs*, const char* name, int size, char* out) {
  return g_below->xFullPathname(g_below, name, size, out);
}
int x_randomness(sqlite3_vfs*, int size, char* out) {
  return g_below->xRandomness(g_below, size, out);
}
int x_sleep(sqlite3_vfs*, int microseconds) {
  return g_below->xSleep(g_below, microseconds);
}
int x_current_time(sqlite3_vfs*, double* out) {
  return g_below->xCurrentTime(g_below, out);
}
int x_get_last_error(sqlite3_vfs*, int size, char* out) {
  return g_below->xGetLastError(g_below, size, out);
}
int x_current_time_int64(sqlite3_vfs*, sqlite3_int64* out) {
  return g_below->xCurrentTimeInt64(g_below, out);
}

bool ends_with(const char* name, const std::string& suffix) {
  if (name == nullptr) return false;
  const std::size_t length = std::strlen(name);
  return length >= suffix.size() &&
         std::memcmp(name + length - suffix.size(), suffix.data(), suffix.size()) == 0;
}

}  // namespace

FaultyVfs::FaultyVfs() {
  if (g_below != nullptr) throw std::logic_error("one FaultyVfs at a time");
  previous_default_ = sqlite3_vfs_find(nullptr);
  g_below = previous_default_;
  vfs_ = new sqlite3_vfs(*g_below);
  vfs_->iVersion = 2;  // no system-call overrides
  vfs_->szOsFile = static_cast<int>(sizeof(FaultyFile)) + g_below->szOsFile;
  vfs_->pNext = nullptr;
  vfs_->zName = "touchmend-faulty";
  vfs_->pAppData = this;
  vfs_->xOpen = x_open;
  vfs_->xDelete = x_delete;
  vfs_->xAccess = x_access;
  vfs_->xFullPathname = x_full_pathname;
  vfs_->xRandomness = x_randomness;
  vfs_->xSleep = x_sleep;
  vfs_->xCurrentTime = x_current_time;
  vfs_->xGetLastError = x_get_last_error;
  vfs_->xCurrentTimeInt64 = x_current_time_int64;
  sqlite3_vfs_register(vfs_, /*makeDflt=*/1);
}

FaultyVfs::~FaultyVfs() {
  sqlite3_vfs_unregister(vfs_);
  sqlite3_vfs_register(previous_default_, /*makeDflt=*/1);
  delete vfs_;
  g_below = nullptr;
}

void FaultyVfs::fail_syncs(const std::string& suffix) {
  std::lock_guard lock(mutex_);
  syncs_failing_ = true;
  sync_suffix_ = suffix;
}

void FaultyVfs::fail_writes_as_full(const std::string& suffix) {
  std::lock_guard lock(mutex_);
  writes_failing_ = true;
  write_suffix_ = suffix;
}

void FaultyVfs::heal() {
  std::lock_guard lock(mutex_);
  syncs_failing_ = writes_failing_ = false;
}

bool FaultyVfs::sync_fails(const char* file) {
  std::lock_guard lock(mutex_);
  const bool fails = syncs_failing_ && ends_with(file, sync_suffix_);
  if (fails) failures_.fetch_add(1);
  return fails;
}

bool FaultyVfs::write_fails(const char* file) {
  std::lock_guard lock(mutex_);
  const bool fails = writes_failing_ && ends_with(file, write_suffix_);
  if (fails) failures_.fetch_add(1);
  return fails;
}

}  // namespace touchmend::testing
