#include "server/service/store.h"

#include <atomic>
#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <sqlite3.h>
#include <sstream>
#include <thread>

#include "server/service/log.h"

namespace touchmend::service {

using rpc::StatusCode;

namespace {

// RAII prepared statement with positional binding helpers.
class Statement {
 public:
  Statement(sqlite3* db, const char* sql) {
    if (sqlite3_prepare_v2(db, sql, -1, &stmt_, nullptr) != SQLITE_OK) stmt_ = nullptr;
  }
  ~Statement() { sqlite3_finalize(stmt_); }
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;

  bool ok() const { return stmt_ != nullptr; }
  void bind(int i, const std::string& text) {
    sqlite3_bind_blob(stmt_, i, text.data(), static_cast<int>(text.size()), SQLITE_TRANSIENT);
  }
  void bind_text(int i, const std::string& text) {
    sqlite3_bind_text(stmt_, i, text.data(), static_cast<int>(text.size()), SQLITE_TRANSIENT);
  }
  void bind(int i, std::int64_t value) { sqlite3_bind_int64(stmt_, i, value); }
  int step() { return sqlite3_step(stmt_); }
  std::string blob(int col) {
    const void* data = sqlite3_column_blob(stmt_, col);
    const int size = sqlite3_column_bytes(stmt_, col);
    return data ? std::string(static_cast<const char*>(data), static_cast<std::size_t>(size))
                : std::string();
  }
  std::string text(int col) {
    const unsigned char* data = sqlite3_column_text(stmt_, col);
    return data ? std::string(reinterpret_cast<const char*>(data)) : std::string();
  }
  std::int64_t integer(int col) { return sqlite3_column_int64(stmt_, col); }

 private:
  sqlite3_stmt* stmt_ = nullptr;
};

std::string join_versions(const std::vector<std::uint64_t>& versions) {
  std::string out;
  for (std::uint64_t v : versions) {
    if (!out.empty()) out += ',';
    out += std::to_string(v);
  }
  return out;
}

std::vector<std::uint64_t> split_versions(const std::string& text) {
  std::vector<std::uint64_t> out;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    if (!item.empty()) out.push_back(std::stoull(item));
  }
  return out;
}

constexpr const char* kSchema = R"sql(
CREATE TABLE IF NOT EXISTS sessions(
  id TEXT PRIMARY KEY, name TEXT NOT NULL, owner TEXT NOT NULL, created_ms INTEGER NOT NULL,
  request_id TEXT NOT NULL DEFAULT '');
CREATE TABLE IF NOT EXISTS session_members(
  session_id TEXT NOT NULL, principal TEXT NOT NULL, PRIMARY KEY(session_id, principal));
CREATE TABLE IF NOT EXISTS journal(
  session_id TEXT NOT NULL, version INTEGER NOT NULL, kind INTEGER NOT NULL,
  target INTEGER NOT NULL, response BLOB NOT NULL, request_id TEXT NOT NULL DEFAULT '',
  mesh_name TEXT NOT NULL DEFAULT '', PRIMARY KEY(session_id, version));
CREATE INDEX IF NOT EXISTS journal_request ON journal(session_id, request_id);
CREATE TABLE IF NOT EXISTS snapshots(
  session_id TEXT NOT NULL, version INTEGER NOT NULL, document BLOB NOT NULL,
  undo TEXT NOT NULL, redo TEXT NOT NULL, mesh_name TEXT NOT NULL DEFAULT '',
  PRIMARY KEY(session_id, version));
CREATE TABLE IF NOT EXISTS jobs(
  id TEXT PRIMARY KEY, principal TEXT NOT NULL, state INTEGER NOT NULL, spec BLOB NOT NULL,
  input BLOB NOT NULL, result BLOB, report BLOB NOT NULL DEFAULT '',
  error_code INTEGER NOT NULL DEFAULT 0, error_message TEXT NOT NULL DEFAULT '',
  attempts INTEGER NOT NULL DEFAULT 0, created_ms INTEGER NOT NULL,
  finished_ms INTEGER NOT NULL DEFAULT 0, result_bytes INTEGER NOT NULL DEFAULT 0);
)sql";

constexpr const char* kSnapshotSchema = R"sql(
CREATE TABLE IF NOT EXISTS snapshots(
  session_id TEXT NOT NULL, version INTEGER NOT NULL, document BLOB NOT NULL,
  undo TEXT NOT NULL, redo TEXT NOT NULL, mesh_name TEXT NOT NULL DEFAULT '',
  PRIMARY KEY(session_id, version));
)sql";

bool exec_ok(sqlite3* db, const char* sql) {
  return sqlite3_exec(db, sql, nullptr, nullptr, nullptr) == SQLITE_OK;
}

//! Opens the snapshot file: WAL, no fsync per commit (NORMAL keeps it consistent across a
//! crash; a snapshot lost to a power cut leaves an older one or the journal), its schema, and an
//! integrity check. Null when any of that fails.
sqlite3* open_snapshot_db(const std::filesystem::path& file) {
  sqlite3* db = nullptr;
  if (sqlite3_open_v2(file.c_str(), &db,
                      SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_FULLMUTEX,
                      nullptr) != SQLITE_OK) {
    sqlite3_close(db);
    return nullptr;
  }
  sqlite3_busy_timeout(db, 5000);
  bool ok = exec_ok(db, "PRAGMA journal_mode=WAL") && exec_ok(db, "PRAGMA synchronous=NORMAL") &&
            exec_ok(db, kSnapshotSchema);
  if (ok) {
    Statement check(db, "PRAGMA quick_check");
    ok = check.ok() && check.step() == SQLITE_ROW && check.text(0) == "ok";
  }
  if (!ok) {
    sqlite3_close(db);
    return nullptr;
  }
  return db;
}

//! The newest snapshot of \p session_id in \p db.
std::optional<SnapshotRow> newest_snapshot(sqlite3* db, const std::string& session_id) {
  Statement st(db,
               "SELECT version,document,undo,redo,mesh_name FROM snapshots WHERE session_id=? "
               "ORDER BY version DESC LIMIT 1");
  st.bind_text(1, session_id);
  if (st.step() != SQLITE_ROW) return std::nullopt;
  SnapshotRow row;
  row.session_id = session_id;
  row.version = static_cast<std::uint64_t>(st.integer(0));
  row.document = st.blob(1);
  row.undo = split_versions(st.text(2));
  row.redo = split_versions(st.text(3));
  row.mesh_name = st.text(4);
  return row;
}

//! What a failed SQLite call on \p db says about the disk under it.
enum class FailureKind { DiskFull, Fatal, Other };

FailureKind classify_failure(sqlite3* db) {
  const int code = sqlite3_extended_errcode(db);
  // A failed sync is fatal whatever its errno (ENOSPC included): the pages it was to flush may
  // be gone from the kernel's cache (SERVICE.md §3.3).
  if (code == SQLITE_IOERR_FSYNC || code == SQLITE_IOERR_DIR_FSYNC) return FailureKind::Fatal;
  // An I/O error whose errno is ENOSPC (a write that could not extend a file) is a full disk
  // too; the errno is the last failed OS call's, so it is asked only of an I/O error.
  if ((code & 0xff) == SQLITE_FULL ||
      ((code & 0xff) == SQLITE_IOERR && sqlite3_system_errno(db) == ENOSPC))
    return FailureKind::DiskFull;
  if (code == SQLITE_IOERR_NOMEM) return FailureKind::Other;  // memory, not the disk
  if ((code & 0xff) == SQLITE_IOERR || (code & 0xff) == SQLITE_CORRUPT ||
      (code & 0xff) == SQLITE_NOTADB)
    return FailureKind::Fatal;
  return FailureKind::Other;
}

}  // namespace

//! Checkpoints the store file's write-ahead log on a thread of its own, through a connection of
//! its own, so no journal commit waits for one. By default SQLite checkpoints in the commit that
//! takes the log past 1,000 pages: that commit then copies 4 MB into the database file and syncs
//! it, and on a mesh of 1.37M faces, whose fills journal 100 kB each, one fill in 40 took 5 ms
//! longer for it (the interactive fill's p99). A passive checkpoint runs beside readers and
//! writers (https://www.sqlite.org/wal.html, "Checkpointing"); the commit after a complete one
//! starts the log over. Should the checkpoints fall behind a stream of commits, the commit that
//! takes the log past kInlinePages checkpoints it itself, as before, so the log stays bounded.
//! A checkpoint that fails for the disk (it writes and syncs the database file) is handed to
//! the store (\p on_failure), which goes fail-stop on an I/O error like a failed commit.
class WalCheckpointer {
 public:
  static constexpr int kRequestPages = 1000;  //!< SQLite's default autocheckpoint
  static constexpr int kInlinePages = 8000;
  using FailureHandler = std::function<void(sqlite3* db, const std::string& what)>;

  //! Null when the file cannot be opened a second time (the store then checkpoints as SQLite
  //! does by default).
  static std::unique_ptr<WalCheckpointer> start(const std::filesystem::path& file,
                                                FailureHandler on_failure) {
    sqlite3* db = nullptr;
    if (sqlite3_open_v2(file.c_str(), &db, SQLITE_OPEN_READWRITE | SQLITE_OPEN_FULLMUTEX,
                        nullptr) != SQLITE_OK ||
        !exec_ok(db, "PRAGMA synchronous=FULL")) {
      sqlite3_close(db);
      return nullptr;
    }
    return std::unique_ptr<WalCheckpointer>(new WalCheckpointer(db, std::move(on_failure)));
  }
  ~WalCheckpointer() {
    {
      std::lock_guard lock(mutex_);
      stop_ = true;
    }
    wake_.notify_one();
    thread_.join();
    sqlite3_close(db_);
  }
  WalCheckpointer(const WalCheckpointer&) = delete;
  WalCheckpointer& operator=(const WalCheckpointer&) = delete;

  //! The store connection's WAL hook: called after each commit with the pages in the log.
  static int on_commit(void* self, sqlite3* db, const char* name, int pages) {
    auto* checkpointer = static_cast<WalCheckpointer*>(self);
    if (pages >= kInlinePages) {
      checkpointer->checkpoint(db, name);
    } else if (pages >= kRequestPages) {
      {
        std::lock_guard lock(checkpointer->mutex_);
        checkpointer->requested_ = true;
      }
      checkpointer->wake_.notify_one();
    }
    return SQLITE_OK;
  }
  std::uint64_t done() const { return done_.load(std::memory_order_relaxed); }

 private:
  WalCheckpointer(sqlite3* db, FailureHandler on_failure)
      : db_(db), on_failure_(std::move(on_failure)), thread_([this] { run(); }) {}
  //! One passive checkpoint through \p db; a busy one is retried at the next commit's request.
  bool checkpoint(sqlite3* db, const char* name) {
    const int rc = sqlite3_wal_checkpoint_v2(db, name, SQLITE_CHECKPOINT_PASSIVE, nullptr, nullptr);
    if (rc == SQLITE_OK) return true;
    if ((rc & 0xff) != SQLITE_BUSY && (rc & 0xff) != SQLITE_LOCKED && on_failure_)
      on_failure_(db, "checkpoint of the write-ahead log");
    return false;
  }
  void run() {
    std::unique_lock lock(mutex_);
    for (;;) {
      wake_.wait(lock, [this] { return stop_ || requested_; });
      if (stop_) return;
      requested_ = false;
      lock.unlock();
      if (checkpoint(db_, nullptr)) done_.fetch_add(1, std::memory_order_relaxed);
      lock.lock();
    }
  }

  sqlite3* db_;
  FailureHandler on_failure_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool requested_ = false;
  bool stop_ = false;
  std::atomic<std::uint64_t> done_{0};
  std::thread thread_;  // last: started once the members it uses are
};

std::filesystem::path Store::snapshot_file(const std::filesystem::path& store_file) {
  return store_file.string() + "-snapshots";
}

std::unique_ptr<Store> Store::open(const std::filesystem::path& file, Status& status,
                                   const StoreOptions& options) {
  sqlite3* db = nullptr;
  if (sqlite3_open_v2(file.c_str(), &db,
                      SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_FULLMUTEX,
                      nullptr) != SQLITE_OK) {
    status = {StatusCode::Unavailable,
              "cannot open store " + file.string() + ": " + (db ? sqlite3_errmsg(db) : "?")};
    sqlite3_close(db);
    return nullptr;
  }
  std::unique_ptr<Store> store(new Store(db));
  store->directory_ = file.parent_path().empty() ? std::filesystem::path(".") : file.parent_path();
  store->options_ = options;
  sqlite3_busy_timeout(db, 5000);
  // WAL + FULL: a commit is on disk when sqlite3_step returns, and readers never block it.
  for (const char* pragma :
       {"PRAGMA journal_mode=WAL", "PRAGMA synchronous=FULL", "PRAGMA foreign_keys=ON"}) {
    if (Status s = store->exec(pragma); !s.is_ok()) {
      status = s;
      return nullptr;
    }
  }
  if (Status s = store->exec(kSchema); !s.is_ok()) {
    status = s;
    return nullptr;
  }
  // Catch a damaged file at start-up rather than on the first edit.
  {
    Statement check(db, "PRAGMA quick_check");
    if (!check.ok() || check.step() != SQLITE_ROW || check.text(0) != "ok") {
      status = {StatusCode::DataLoss, "store " + file.string() + " failed its integrity check"};
      return nullptr;
    }
  }
  store->checkpointer_ =
      WalCheckpointer::start(file, [raw = store.get()](sqlite3* failed, const std::string& what) {
        (void)raw->failure(failed, what);
      });
  if (store->checkpointer_)
    sqlite3_wal_hook(db, &WalCheckpointer::on_commit, store->checkpointer_.get());
  // The snapshot file holds nothing the journal does not: a damaged one is set aside (renamed,
  // not deleted) and a new one started; if even that fails, snapshots stay in the store file.
  const std::filesystem::path snapshots = snapshot_file(file);
  store->snapshot_db_ = open_snapshot_db(snapshots);
  if (store->snapshot_db_ == nullptr) {
    std::error_code ignored;
    for (const char* suffix : {"", "-wal", "-shm"})
      std::filesystem::rename(snapshots.string() + suffix, snapshots.string() + ".damaged" + suffix,
                              ignored);
    store->snapshot_db_ = open_snapshot_db(snapshots);
  }
  status = {};
  return store;
}

Store::Store(sqlite3* db) : db_(db) {}

Store::~Store() {
  if (checkpointer_) {
    sqlite3_wal_hook(db_, nullptr, nullptr);
    checkpointer_.reset();
  }
  sqlite3_close(snapshot_db_);
  sqlite3_close(db_);
}

std::uint64_t Store::background_checkpoints() const {
  return checkpointer_ ? checkpointer_->done() : 0;
}

StoreCondition Store::condition() {
  // A full disk that has room again is ready again, before any write finds out: a load
  // balancer or a client waiting for readiness would otherwise never send the write that ends
  // the condition.
  if (health_.load() == StoreHealth::DiskFull) {
    std::error_code ec;
    const std::filesystem::space_info space = std::filesystem::space(directory_, ec);
    if (!ec && space.available >= options_.room_to_resume) wrote();
  }
  std::lock_guard lock(condition_mutex_);
  return {health_.load(), condition_reason_};
}

Status Store::failure(sqlite3* db, const std::string& what) {
  const int code = sqlite3_extended_errcode(db);
  const char* call = code == SQLITE_IOERR_FSYNC || code == SQLITE_IOERR_DIR_FSYNC   ? "fsync, "
                     : code == SQLITE_IOERR_WRITE                                   ? "write, "
                     : code == SQLITE_IOERR_READ || code == SQLITE_IOERR_SHORT_READ ? "read, "
                     : code == SQLITE_IOERR_TRUNCATE                                ? "truncate, "
                                                                                    : "";
  const std::string detail =
      what + ": " + sqlite3_errmsg(db) + " (" + call + "SQLite code " + std::to_string(code) + ")";
  switch (classify_failure(db)) {
    case FailureKind::Fatal:
      fail_stop(detail);
      // What this write sent may or may not have reached the disk: a commit whose sync failed
      // can be found complete in the log at the restart (PostgreSQL's commits after a PANIC
      // are the same). An edit sent with a request_id and sent again after the restart is
      // answered once either way.
      return {StatusCode::Unavailable,
              condition().reason +
                  ": not acknowledged; whether this write is in the journal is known only after "
                  "the server is restarted (send an edit again then, with the same request_id); "
                  "until then the server accepts no edits"};
    case FailureKind::DiskFull: {
      disk_full_refusals_.fetch_add(1, std::memory_order_relaxed);
      bool began = false;
      {
        std::lock_guard lock(condition_mutex_);
        if (health_.load() == StoreHealth::Ok) {
          health_.store(StoreHealth::DiskFull);
          condition_reason_ = "the store's disk is full (" + detail + ")";
          began = true;
        }
      }
      if (began) log_event(spdlog::level::warn, "store_disk_full", {{"msg", detail}});
      return {StatusCode::ResourceExhausted,
              "the store's disk is full (" + detail +
                  "): edits are refused until space is freed, then taken again"};
    }
    case FailureKind::Other:
      break;
  }
  return {StatusCode::Internal, "store: " + detail};
}

void Store::fail_stop(const std::string& reason) {
  {
    std::lock_guard lock(condition_mutex_);
    if (health_.load() == StoreHealth::Failed) return;
    health_.store(StoreHealth::Failed);
    condition_reason_ = "the store failed (" + reason + ")";
  }
  log_event(spdlog::level::critical, "store_failed",
            {{"msg", reason},
             {"action",
              "no more edits are written or acknowledged; restart the server to "
              "recover from the journal"}});
}

Status Store::refusal() {
  if (health_.load() != StoreHealth::Failed) return {};
  return {StatusCode::Unavailable,
          condition().reason +
              ": refused; the server accepts no edits until it is restarted (recovery replays the "
              "journal; nothing acknowledged is lost)"};
}

void Store::wrote() {
  if (health_.load() != StoreHealth::DiskFull) return;
  {
    std::lock_guard lock(condition_mutex_);
    if (health_.load() != StoreHealth::DiskFull) return;
    health_.store(StoreHealth::Ok);
    condition_reason_.clear();
  }
  log_event(spdlog::level::info, "store_writable", {{"msg", "the store's disk has room again"}});
}

Status Store::exec(const char* sql, const char* what) {
  if (sqlite3_exec(db_, sql, nullptr, nullptr, nullptr) != SQLITE_OK)
    return failure(db_, std::string(what) + ": " + sql);
  return {};
}

Status Store::insert_session(const SessionRow& row) {
  if (Status s = refusal(); !s.is_ok()) return s;
  std::lock_guard lock(mutex_);
  Statement st(db_, "INSERT INTO sessions(id,name,owner,created_ms,request_id) VALUES(?,?,?,?,?)");
  st.bind_text(1, row.id);
  st.bind_text(2, row.name);
  st.bind_text(3, row.owner);
  st.bind(4, row.created_ms);
  st.bind_text(5, row.request_id);
  if (st.step() != SQLITE_DONE) return error("insert session");
  wrote();
  return {};
}

Status Store::delete_session(const std::string& id) {
  // The snapshot file first: a crash between the two leaves the session with its journal (and
  // its load's snapshot), which recovers it; the other order could leave snapshots of a deleted
  // session behind.
  if (Status s = refusal(); !s.is_ok()) return s;
  if (snapshot_db_ != nullptr) {
    std::lock_guard lock(snapshot_mutex_);
    Statement st(snapshot_db_, "DELETE FROM snapshots WHERE session_id=?");
    st.bind_text(1, id);
    if (st.step() != SQLITE_DONE) return failure(snapshot_db_, "delete session snapshots");
  }
  std::lock_guard lock(mutex_);
  if (Status s = exec("BEGIN IMMEDIATE"); !s.is_ok()) return s;
  for (const char* sql :
       {"DELETE FROM sessions WHERE id=?", "DELETE FROM session_members WHERE session_id=?",
        "DELETE FROM journal WHERE session_id=?", "DELETE FROM snapshots WHERE session_id=?"}) {
    Statement st(db_, sql);
    st.bind_text(1, id);
    if (st.step() != SQLITE_DONE) {
      Status s = error("delete session");
      exec("ROLLBACK");
      return s;
    }
  }
  if (Status s = exec("COMMIT", "delete session"); !s.is_ok()) {
    exec("ROLLBACK");
    return s;
  }
  wrote();
  return {};
}

Status Store::set_member(const std::string& session_id, const std::string& principal,
                         bool present) {
  if (Status s = refusal(); !s.is_ok()) return s;
  std::lock_guard lock(mutex_);
  Statement st(db_, present
                        ? "INSERT OR IGNORE INTO session_members(session_id,principal) VALUES(?,?)"
                        : "DELETE FROM session_members WHERE session_id=? AND principal=?");
  st.bind_text(1, session_id);
  st.bind_text(2, principal);
  if (st.step() != SQLITE_DONE) return error("set member");
  wrote();
  return {};
}

std::vector<SessionRow> Store::load_sessions() {
  std::lock_guard lock(mutex_);
  std::vector<SessionRow> rows;
  Statement st(db_,
               "SELECT id,name,owner,created_ms,request_id FROM sessions ORDER BY created_ms,id");
  while (st.step() == SQLITE_ROW) {
    rows.push_back({st.text(0), st.text(1), st.text(2), {}, st.integer(3), st.text(4)});
  }
  for (auto& row : rows) {
    Statement m(db_, "SELECT principal FROM session_members WHERE session_id=? ORDER BY principal");
    m.bind_text(1, row.id);
    while (m.step() == SQLITE_ROW) row.members.push_back(m.text(0));
  }
  return rows;
}

namespace {
bool insert_snapshot(sqlite3* db, const SnapshotRow& row) {
  Statement st(db,
               "INSERT OR REPLACE INTO snapshots(session_id,version,document,undo,redo,mesh_name) "
               "VALUES(?,?,?,?,?,?)");
  st.bind_text(1, row.session_id);
  st.bind(2, static_cast<std::int64_t>(row.version));
  st.bind(3, row.document);
  st.bind_text(4, join_versions(row.undo));
  st.bind_text(5, join_versions(row.redo));
  st.bind_text(6, row.mesh_name);
  return st.step() == SQLITE_DONE;
}
}  // namespace

Status Store::append_journal(const JournalRow& row, const SnapshotRow* snapshot) {
  if (Status s = refusal(); !s.is_ok()) return s;
  std::lock_guard lock(mutex_);
  const auto start = std::chrono::steady_clock::now();
  if (Status s = exec("BEGIN IMMEDIATE"); !s.is_ok()) return s;
  Statement st(db_,
               "INSERT INTO journal(session_id,version,kind,target,response,request_id,mesh_name) "
               "VALUES(?,?,?,?,?,?,?)");
  st.bind_text(1, row.session_id);
  st.bind(2, static_cast<std::int64_t>(row.version));
  st.bind(3, static_cast<std::int64_t>(row.kind));
  st.bind(4, static_cast<std::int64_t>(row.target));
  st.bind(5, row.response);
  st.bind_text(6, row.request_id);
  st.bind_text(7, row.mesh_name);
  if (st.step() != SQLITE_DONE || (snapshot && !insert_snapshot(db_, *snapshot))) {
    Status s = error("journal append");
    exec("ROLLBACK");
    return s;
  }
  if (snapshot) {
    // A load's snapshot supersedes the store file's older ones (the previous load's; periodic
    // ones from before the snapshot file), in the same transaction.
    Statement older(db_, "DELETE FROM snapshots WHERE session_id=? AND version<?");
    older.bind_text(1, snapshot->session_id);
    older.bind(2, static_cast<std::int64_t>(snapshot->version));
    if (older.step() != SQLITE_DONE) {
      Status s = error("journal append");
      exec("ROLLBACK");
      return s;
    }
  }
  if (Status s = exec("COMMIT", "journal append"); !s.is_ok()) {
    exec("ROLLBACK");
    return s;
  }
  last_commit_seconds_ =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  wrote();
  return {};
}

Status Store::write_snapshot(const SnapshotRow& row) {
  if (Status s = refusal(); !s.is_ok()) return s;
  if (snapshot_db_ != nullptr) {
    {
      std::lock_guard lock(snapshot_mutex_);
      // One transaction: a crash never leaves the new snapshot missing with the older ones
      // already deleted.
      if (!exec_ok(snapshot_db_, "BEGIN IMMEDIATE")) return failure(snapshot_db_, "snapshot");
      Statement st(snapshot_db_, "DELETE FROM snapshots WHERE session_id=? AND version<?");
      st.bind_text(1, row.session_id);
      st.bind(2, static_cast<std::int64_t>(row.version));
      if (!insert_snapshot(snapshot_db_, row) || st.step() != SQLITE_DONE ||
          !exec_ok(snapshot_db_, "COMMIT")) {
        Status s = failure(snapshot_db_, "snapshot");
        exec_ok(snapshot_db_, "ROLLBACK");
        return s;
      }
    }
    wrote();
    // The store file's snapshot of the session (its last load's) stays until the next load
    // replaces it: deleting a large one here took the journal's lock for tens of milliseconds.
    return {};
  }
  std::lock_guard lock(mutex_);
  // A snapshot only shortens recovery (the journal past it is replayed), so it skips its own
  // fsync: in WAL mode synchronous=NORMAL still keeps the database consistent across a crash,
  // and the next journal commit (FULL) makes these pages durable too. One transaction, so a
  // crash never leaves the new snapshot missing with the older ones already deleted.
  exec("PRAGMA synchronous=NORMAL");
  Status result;
  if (result = exec("BEGIN IMMEDIATE"); result.is_ok()) {
    Statement st(db_, "DELETE FROM snapshots WHERE session_id=? AND version<?");
    st.bind_text(1, row.session_id);
    st.bind(2, static_cast<std::int64_t>(row.version));
    if (!insert_snapshot(db_, row) || st.step() != SQLITE_DONE) {
      result = error("snapshot");
      exec("ROLLBACK");
    } else if (result = exec("COMMIT", "snapshot"); !result.is_ok()) {
      exec("ROLLBACK");
    }
  }
  exec("PRAGMA synchronous=FULL");
  if (result.is_ok()) wrote();
  return result;
}

std::optional<SnapshotRow> Store::latest_snapshot(const std::string& session_id) {
  std::optional<SnapshotRow> periodic;
  if (snapshot_db_ != nullptr) {
    std::lock_guard lock(snapshot_mutex_);
    periodic = newest_snapshot(snapshot_db_, session_id);
  }
  std::lock_guard lock(mutex_);
  std::optional<SnapshotRow> stored = newest_snapshot(db_, session_id);
  if (!stored || (periodic && periodic->version > stored->version)) return periodic;
  return stored;
}

namespace {
JournalRow read_journal_row(Statement& st, const std::string& session_id) {
  JournalRow row;
  row.session_id = session_id;
  row.version = static_cast<std::uint64_t>(st.integer(0));
  row.kind = static_cast<JournalKind>(st.integer(1));
  row.target = static_cast<std::uint64_t>(st.integer(2));
  row.response = st.blob(3);
  row.request_id = st.text(4);
  row.mesh_name = st.text(5);
  return row;
}
constexpr const char* kJournalColumns = "version,kind,target,response,request_id,mesh_name";
}  // namespace

std::vector<JournalRow> Store::journal_after(const std::string& session_id, std::uint64_t after,
                                             std::size_t limit) {
  std::lock_guard lock(mutex_);
  std::vector<JournalRow> rows;
  const std::string sql = std::string("SELECT ") + kJournalColumns +
                          " FROM journal WHERE session_id=? AND version>? ORDER BY version LIMIT ?";
  Statement st(db_, sql.c_str());
  st.bind_text(1, session_id);
  st.bind(2, static_cast<std::int64_t>(after));
  st.bind(3, static_cast<std::int64_t>(limit));
  while (st.step() == SQLITE_ROW) rows.push_back(read_journal_row(st, session_id));
  return rows;
}

std::optional<JournalRow> Store::journal_entry(const std::string& session_id,
                                               std::uint64_t version) {
  std::lock_guard lock(mutex_);
  const std::string sql =
      std::string("SELECT ") + kJournalColumns + " FROM journal WHERE session_id=? AND version=?";
  Statement st(db_, sql.c_str());
  st.bind_text(1, session_id);
  st.bind(2, static_cast<std::int64_t>(version));
  if (st.step() != SQLITE_ROW) return std::nullopt;
  return read_journal_row(st, session_id);
}

std::optional<JournalRow> Store::journal_by_request(const std::string& session_id,
                                                    const std::string& request_id) {
  std::lock_guard lock(mutex_);
  const std::string sql = std::string("SELECT ") + kJournalColumns +
                          " FROM journal WHERE session_id=? AND request_id=? LIMIT 1";
  Statement st(db_, sql.c_str());
  st.bind_text(1, session_id);
  st.bind_text(2, request_id);
  if (st.step() != SQLITE_ROW) return std::nullopt;
  return read_journal_row(st, session_id);
}

Status Store::insert_job(const JobRow& row, const std::string& input) {
  if (Status s = refusal(); !s.is_ok()) return s;
  std::lock_guard lock(mutex_);
  Statement st(db_,
               "INSERT INTO jobs(id,principal,state,spec,input,created_ms) VALUES(?,?,?,?,?,?)");
  st.bind_text(1, row.id);
  st.bind_text(2, row.principal);
  st.bind(3, static_cast<std::int64_t>(row.state));
  st.bind(4, row.spec);
  st.bind(5, input);
  st.bind(6, row.created_ms);
  if (st.step() != SQLITE_DONE) return error("insert job");
  wrote();
  return {};
}

Status Store::update_job(const JobRow& row) {
  if (Status s = refusal(); !s.is_ok()) return s;
  std::lock_guard lock(mutex_);
  Statement st(db_,
               "UPDATE jobs SET state=?,report=?,error_code=?,error_message=?,attempts=?,"
               "finished_ms=? WHERE id=?");
  st.bind(1, static_cast<std::int64_t>(row.state));
  st.bind(2, row.report);
  st.bind(3, static_cast<std::int64_t>(row.error_code));
  st.bind_text(4, row.error_message);
  st.bind(5, static_cast<std::int64_t>(row.attempts));
  st.bind(6, row.finished_ms);
  st.bind_text(7, row.id);
  if (st.step() != SQLITE_DONE) return error("update job");
  wrote();
  return {};
}

Status Store::set_job_result(const JobRow& row, const std::string& result) {
  if (Status s = refusal(); !s.is_ok()) return s;
  std::lock_guard lock(mutex_);
  Statement st(db_,
               "UPDATE jobs SET state=?,report=?,error_code=0,error_message='',attempts=?,"
               "finished_ms=?,result=?,result_bytes=?,input=x'' WHERE id=?");
  st.bind(1, static_cast<std::int64_t>(row.state));
  st.bind(2, row.report);
  st.bind(3, static_cast<std::int64_t>(row.attempts));
  st.bind(4, row.finished_ms);
  st.bind(5, result);
  st.bind(6, static_cast<std::int64_t>(result.size()));
  st.bind_text(7, row.id);
  if (st.step() != SQLITE_DONE) return error("job result");
  wrote();
  return {};
}

std::vector<JobRow> Store::load_jobs() {
  std::lock_guard lock(mutex_);
  std::vector<JobRow> rows;
  Statement st(db_,
               "SELECT id,principal,state,spec,report,error_code,error_message,attempts,"
               "created_ms,finished_ms,result_bytes FROM jobs ORDER BY created_ms,id");
  while (st.step() == SQLITE_ROW) {
    JobRow row;
    row.id = st.text(0);
    row.principal = st.text(1);
    row.state = static_cast<int>(st.integer(2));
    row.spec = st.blob(3);
    row.report = st.blob(4);
    row.error_code = static_cast<int>(st.integer(5));
    row.error_message = st.text(6);
    row.attempts = static_cast<std::uint32_t>(st.integer(7));
    row.created_ms = st.integer(8);
    row.finished_ms = st.integer(9);
    row.result_bytes = static_cast<std::uint64_t>(st.integer(10));
    rows.push_back(std::move(row));
  }
  return rows;
}

std::optional<std::string> Store::job_input(const std::string& id) {
  std::lock_guard lock(mutex_);
  Statement st(db_, "SELECT input FROM jobs WHERE id=?");
  st.bind_text(1, id);
  if (st.step() != SQLITE_ROW) return std::nullopt;
  return st.blob(0);
}

std::optional<std::string> Store::job_result(const std::string& id) {
  std::lock_guard lock(mutex_);
  Statement st(db_, "SELECT result FROM jobs WHERE id=? AND result IS NOT NULL");
  st.bind_text(1, id);
  if (st.step() != SQLITE_ROW) return std::nullopt;
  return st.blob(0);
}

Status Store::delete_job(const std::string& id) {
  if (Status s = refusal(); !s.is_ok()) return s;
  std::lock_guard lock(mutex_);
  Statement st(db_, "DELETE FROM jobs WHERE id=?");
  st.bind_text(1, id);
  if (st.step() != SQLITE_DONE) return error("delete job");
  wrote();
  return {};
}

}  // namespace touchmend::service
