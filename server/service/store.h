#pragma once

//! \file store.h
//! \brief The embedded durable store (SQLite in WAL mode, synchronous=FULL): sessions and
//! their members, the journal of edits, snapshots, and fill jobs. Every write returns only
//! after SQLite has committed it to disk, so an edit is journaled before it is acknowledged
//! (DESIGN.md "Reliability rules"; SERVICE.md §3, measured 0.26 ms p50 per commit).
//!
//! Thread-safe: one connection behind a mutex (commits are short; the journal is the only
//! hot path and its rows are small).

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "proto/rpc/status.h"

struct sqlite3;

namespace touchmend::service {

class WalCheckpointer;

using rpc::Status;

enum class JournalKind : int { Load = 1, Edit = 2, Undo = 3, Redo = 4 };

struct SessionRow {
  std::string id;
  std::string name;
  std::string owner;
  std::vector<std::string> members;
  std::int64_t created_ms = 0;
  std::string request_id;
};

struct JournalRow {
  std::string session_id;
  std::uint64_t version = 0;
  JournalKind kind = JournalKind::Edit;
  std::uint64_t target = 0;  //!< Undo/Redo: the Edit version undone or redone
  std::string response;      //!< serialized v1::EditResponse (its delta is the edit)
  std::string request_id;
  std::string mesh_name;  //!< Load only
};

struct SnapshotRow {
  std::string session_id;
  std::uint64_t version = 0;
  std::string document;  //!< serialized v1::MeshDocument
  std::vector<std::uint64_t> undo;
  std::vector<std::uint64_t> redo;
  std::string mesh_name;
};

struct JobRow {
  std::string id;
  std::string principal;
  int state = 0;       //!< v1::JobState
  std::string spec;    //!< serialized v1::JobSpec
  std::string report;  //!< serialized v1::FillReport
  int error_code = 0;
  std::string error_message;
  std::uint32_t attempts = 0;
  std::int64_t created_ms = 0;
  std::int64_t finished_ms = 0;
  std::uint64_t result_bytes = 0;
};

//! Whether the store takes writes (SERVICE.md §3.3, "fsync errors are fatal", "Disk full").
enum class StoreHealth : int {
  Ok = 0,
  //! The last write found the disk full (ENOSPC): writes are refused with RESOURCE_EXHAUSTED
  //! until one gets through again, which ends the condition without a restart.
  DiskFull = 1,
  //! A write or sync failed with an I/O error (or the file is corrupt): the store is fail-stop.
  //! Data the kernel had cached may have been dropped at write-back, and a retried sync can
  //! report success without having flushed it (PostgreSQL's "fsyncgate"), so nothing is written
  //! or acknowledged again until the server is restarted and recovers from the journal.
  Failed = 2,
};

struct StoreCondition {
  StoreHealth health = StoreHealth::Ok;
  std::string reason;  //!< empty when Ok
};

struct StoreOptions {
  //! Free space on the store's file system that ends a full-disk condition before a write
  //! does (condition()): enough for a few edits' journal entries.
  std::uintmax_t room_to_resume = std::uintmax_t{1} << 20;
};

class Store {
 public:
  //! Opens (creating if needed) the store file and its schema.
  static std::unique_ptr<Store> open(const std::filesystem::path& file, Status& status,
                                     const StoreOptions& options = {});
  ~Store();
  Store(const Store&) = delete;
  Store& operator=(const Store&) = delete;

  Status insert_session(const SessionRow& row);
  Status delete_session(const std::string& id);
  Status set_member(const std::string& session_id, const std::string& principal, bool present);
  std::vector<SessionRow> load_sessions();

  //! Durable when it returns OK. A Load row is written with its snapshot in one transaction.
  Status append_journal(const JournalRow& row, const SnapshotRow* snapshot = nullptr);
  //! A periodic snapshot. It goes to the snapshot file beside the store (snapshot_file()), with
  //! its own connection and lock: writing a large document there takes tens of milliseconds
  //! (45-67 ms for a 400k-face mesh), and in the store file it held the journal's lock that long,
  //! so the edit after it waited (the interactive fill's p99 on large meshes). A snapshot only
  //! shortens recovery (the journal past it is replayed), so that file is written without fsync
  //! and a damaged one is set aside and started afresh. Without that file (it could not be
  //! opened), snapshots go to the store file as before. The store file keeps the session's
  //! last load's snapshot (append_journal replaces it at the next load).
  Status write_snapshot(const SnapshotRow& row);
  //! The newest snapshot of the session in either file (a load's is in the store file).
  std::optional<SnapshotRow> latest_snapshot(const std::string& session_id);
  //! The snapshot file beside \p store_file.
  static std::filesystem::path snapshot_file(const std::filesystem::path& store_file);
  //! Whether periodic snapshots go to their own file (false when it could not be opened).
  bool has_snapshot_file() const { return snapshot_db_ != nullptr; }
  std::vector<JournalRow> journal_after(const std::string& session_id, std::uint64_t after,
                                        std::size_t limit);
  std::optional<JournalRow> journal_entry(const std::string& session_id, std::uint64_t version);
  std::optional<JournalRow> journal_by_request(const std::string& session_id,
                                               const std::string& request_id);

  Status insert_job(const JobRow& row, const std::string& input);
  Status update_job(const JobRow& row);
  Status set_job_result(const JobRow& row, const std::string& result);
  std::vector<JobRow> load_jobs();
  std::optional<std::string> job_input(const std::string& id);
  std::optional<std::string> job_result(const std::string& id);
  Status delete_job(const std::string& id);

  //! Seconds spent in the last journal commit (for /metrics).
  double last_commit_seconds() const { return last_commit_seconds_; }
  //! Checkpoints of the store file's write-ahead log made beside the journal's commits (for
  //! /metrics and tests; see WalCheckpointer in store.cpp). Zero when the store checkpoints in its
  //! commits, as SQLite does by default (the checkpointer's connection could not be opened).
  std::uint64_t background_checkpoints() const;

  //! Whether the store takes writes, and why not (for readiness, Health and /metrics). A full
  //! disk is over once a write goes through again or its file system has
  //! StoreOptions::room_to_resume free.
  StoreCondition condition();
  //! Writes refused because the disk was full (for /metrics).
  std::uint64_t disk_full_refusals() const {
    return disk_full_refusals_.load(std::memory_order_relaxed);
  }

 private:
  explicit Store(sqlite3* db);
  //! Runs \p sql; a failure is reported as part of \p what.
  Status exec(const char* sql, const char* what = "store");
  //! The status for the failed call \p what on \p db, from SQLite's extended error code: a full
  //! disk is RESOURCE_EXHAUSTED (and the condition DiskFull), an I/O error or a corrupt file
  //! makes the store fail-stop (UNAVAILABLE from then on), anything else is INTERNAL.
  Status failure(sqlite3* db, const std::string& what);
  Status error(const char* what) { return failure(db_, what); }
  //! Non-OK (UNAVAILABLE) once the store has failed: every write starts with it.
  Status refusal();
  //! Makes the store fail-stop for \p reason (the first reason is kept).
  void fail_stop(const std::string& reason);
  //! A write went through: a full disk has room again.
  void wrote();

  sqlite3* db_;
  std::mutex mutex_;
  sqlite3* snapshot_db_ = nullptr;  //!< periodic snapshots (write_snapshot)
  std::mutex snapshot_mutex_;
  double last_commit_seconds_ = 0;
  std::unique_ptr<WalCheckpointer> checkpointer_;
  std::filesystem::path directory_;  //!< the store file's, for its free space
  StoreOptions options_;
  std::atomic<StoreHealth> health_{StoreHealth::Ok};
  std::mutex condition_mutex_;
  std::string condition_reason_;  //!< guarded by condition_mutex_
  std::atomic<std::uint64_t> disk_full_refusals_{0};
};

}  // namespace touchmend::service
