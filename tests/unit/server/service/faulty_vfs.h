#pragma once

//! \file faulty_vfs.h
//! \brief A SQLite VFS over the default one that fails chosen calls on chosen files, for the
//! store's fault tests (SERVICE.md §5.3, "fsync EIO" and "Disk full"): a sync that fails with
//! EIO, a write that finds the disk full. It is the default VFS while it lives, so every
//! connection opened meanwhile (the store's, its checkpointer's, the snapshot file's) goes
//! through it; faults start and stop at any time, also for files already open.

#include <atomic>
#include <cstdint>
#include <mutex>
#include <string>

struct sqlite3_vfs;

namespace touchmend::testing {

class FaultyVfs {
 public:
  FaultyVfs();
  ~FaultyVfs();
  FaultyVfs(const FaultyVfs&) = delete;
  FaultyVfs& operator=(const FaultyVfs&) = delete;

  //! From now on every sync of a file whose name ends with \p suffix fails as fsync does on an
  //! I/O error (SQLITE_IOERR_FSYNC, errno EIO); the data written before stays written.
  void fail_syncs(const std::string& suffix);
  //! From now on every write to a file whose name ends with \p suffix ("" for every file) fails
  //! as on a full disk (SQLITE_FULL, errno ENOSPC), writing nothing.
  void fail_writes_as_full(const std::string& suffix);
  //! No more faults.
  void heal();
  //! Calls failed so far.
  std::uint64_t failures() const { return failures_.load(); }

  //! For the VFS's callbacks: whether a sync (write) of \p file is to fail now.
  bool sync_fails(const char* file);
  bool write_fails(const char* file);

 private:
  sqlite3_vfs* vfs_;
  sqlite3_vfs* previous_default_;
  std::mutex mutex_;
  bool syncs_failing_ = false;
  std::string sync_suffix_;
  bool writes_failing_ = false;
  std::string write_suffix_;
  std::atomic<std::uint64_t> failures_{0};
};

}  // namespace touchmend::testing
