// Session: slot reuse keeps the document bounded across fill/undo cycles, the history stays
// right when new edits reuse the slots of undone ones, and recovery from the journal rebuilds
// exactly the same document.

#include "server/service/session.h"

#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <random>
#include <sqlite3.h>
#include <thread>

#include <gtest/gtest.h>

#include "server/service/metrics.h"
#include "server/service/store.h"
#include "tests/support/mesh_factory.h"
#include "tests/unit/server/service/faulty_vfs.h"

namespace touchmend::service {
namespace {

namespace fs = std::filesystem;

std::string sample() {
  std::string bytes;
  std::ifstream in(TOUCHMEND_SAMPLE_MESH, std::ios::binary);
  bytes.assign(std::istreambuf_iterator<char>(in), {});
  return bytes;
}

class SessionTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ =
        fs::temp_directory_path() / ("touchmend-session-" + std::to_string(std::random_device{}()));
    fs::create_directories(dir_);
    store_ = open_store();
    row_.id = "s1";
    row_.name = "test";
    row_.owner = "local";
    ASSERT_TRUE(store_->insert_session(row_).is_ok());
  }
  void TearDown() override {
    store_.reset();
    fs::remove_all(dir_);
  }
  std::unique_ptr<Store> open_store() {
    Status status;
    // The disk-full tests' disk is full only for the store (their VFS says so), so free space
    // never ends the condition here.
    StoreOptions options;
    options.room_to_resume = std::numeric_limits<std::uintmax_t>::max();
    auto store = Store::open(dir_ / "touchmend.db", status, options);
    EXPECT_TRUE(store) << status.to_string();
    return store;
  }
  std::shared_ptr<Session> make_session() {
    SessionOptions options;
    options.snapshot_every = 1'000'000;  // no snapshot task racing the test thread
    return std::make_shared<Session>(row_, *store_, pool_, metrics_, options);
  }
  //! Loads the sample (Spot with three holes) into \p s.
  static bool load_sample(Session& s) {
    LoadedMesh loaded;
    if (!load_document(sample(), geometry::MeshFormat::Off, {}, loaded).is_ok()) return false;
    v1::LoadMeshResponse response;
    return s.load(std::move(loaded), "spot", "local", response).is_ok();
  }
  static std::vector<std::uint32_t> hole_ids(Session& s) {
    std::vector<std::uint32_t> ids;
    for (const auto& h : s.holes()) ids.push_back(h.id());
    return ids;
  }
  static Status fill_one(Session& s, std::uint32_t hole, v1::EditResponse& response) {
    v1::FillHolesRequest request;
    request.set_session_id("s1");
    request.mutable_selection()->mutable_ids()->add_ids(hole);
    return s.fill(request, "local", nullptr, response);
  }

  fs::path dir_;
  std::unique_ptr<Store> store_;
  SessionRow row_;
  asio::thread_pool pool_{1};
  Metrics metrics_;
};

//! A snapshot row of \p document bytes at \p version.
SnapshotRow snapshot_at(std::uint64_t version, const std::string& document) {
  SnapshotRow row;
  row.session_id = "s1";
  row.version = version;
  row.document = document;
  row.undo = {version};
  row.mesh_name = "m";
  return row;
}

// Periodic snapshots go to their own file (so writing one never holds the journal's lock); a
// load's snapshot stays in the store file with its journal row. The newest of the two is the
// one recovery starts from, across a reopen; deleting the session deletes both.
TEST_F(SessionTest, PeriodicSnapshotsHaveTheirOwnFileAndTheNewestWins) {
  ASSERT_TRUE(store_->has_snapshot_file());
  EXPECT_TRUE(fs::exists(Store::snapshot_file(dir_ / "touchmend.db")));
  JournalRow load;
  load.session_id = "s1";
  load.version = 1;
  load.kind = JournalKind::Load;
  load.response = "r";
  const SnapshotRow loaded = snapshot_at(1, "A");
  ASSERT_TRUE(store_->append_journal(load, &loaded).is_ok());
  ASSERT_TRUE(store_->write_snapshot(snapshot_at(5, "B")).is_ok());
  auto latest = store_->latest_snapshot("s1");
  ASSERT_TRUE(latest);
  EXPECT_EQ(latest->version, 5u);
  EXPECT_EQ(latest->document, "B");
  EXPECT_EQ(latest->undo, std::vector<std::uint64_t>{5});
  // A later load's snapshot (store file) is newer than the periodic one.
  load.version = 7;
  const SnapshotRow reloaded = snapshot_at(7, "C");
  ASSERT_TRUE(store_->append_journal(load, &reloaded).is_ok());
  EXPECT_EQ(store_->latest_snapshot("s1")->document, "C");
  {
    // The second load's snapshot replaced the first in the store file.
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open_v2((dir_ / "touchmend.db").c_str(), &db, SQLITE_OPEN_READONLY, nullptr),
              SQLITE_OK);
    sqlite3_stmt* st = nullptr;
    ASSERT_EQ(sqlite3_prepare_v2(db, "SELECT count(*) FROM snapshots WHERE session_id='s1'", -1,
                                 &st, nullptr),
              SQLITE_OK);
    ASSERT_EQ(sqlite3_step(st), SQLITE_ROW);
    EXPECT_EQ(sqlite3_column_int(st, 0), 1);
    sqlite3_finalize(st);
    sqlite3_close(db);
  }
  ASSERT_TRUE(store_->write_snapshot(snapshot_at(9, "D")).is_ok());
  store_.reset();
  store_ = open_store();
  ASSERT_TRUE(store_);
  latest = store_->latest_snapshot("s1");
  ASSERT_TRUE(latest);
  EXPECT_EQ(latest->version, 9u);
  EXPECT_EQ(latest->document, "D");
  ASSERT_TRUE(store_->delete_session("s1").is_ok());
  EXPECT_FALSE(store_->latest_snapshot("s1"));
}

// The snapshot file holds nothing the journal does not: a damaged one is set aside and a new
// one started, and the store opens.
TEST_F(SessionTest, ADamagedSnapshotFileIsSetAside) {
  store_.reset();
  const fs::path file = Store::snapshot_file(dir_ / "touchmend.db");
  fs::remove(file.string() + "-wal");
  fs::remove(file.string() + "-shm");
  {
    std::ofstream out(file, std::ios::binary | std::ios::trunc);
    out << std::string(8192, 'x');
  }
  store_ = open_store();
  ASSERT_TRUE(store_);
  EXPECT_TRUE(store_->has_snapshot_file());
  EXPECT_TRUE(fs::exists(file.string() + ".damaged"));
  ASSERT_TRUE(store_->write_snapshot(snapshot_at(3, "E")).is_ok());
  ASSERT_TRUE(store_->latest_snapshot("s1"));
  EXPECT_EQ(store_->latest_snapshot("s1")->document, "E");
}

//! The session test's store, opened through a VFS that fails syncs and writes on request.
class StoreFaultTest : public SessionTest {
 protected:
  //! A journal row of \p bytes random bytes at \p version.
  static JournalRow journal_row(std::uint64_t version, std::size_t bytes = 64) {
    JournalRow row;
    row.session_id = "s1";
    row.version = version;
    row.kind = JournalKind::Edit;
    row.response.resize(bytes);
    std::mt19937 random(static_cast<unsigned>(version));
    for (char& c : row.response) c = static_cast<char>(random());
    return row;
  }
  //! The versions of the journal rows \p store holds.
  static std::vector<std::uint64_t> versions(Store& store) {
    std::vector<std::uint64_t> out;
    for (const JournalRow& row : store.journal_after("s1", 0, 100000)) out.push_back(row.version);
    return out;
  }

  //! Whether \p a and \p b have the same alive vertices and faces in the same slots (a slot one
  //! of them has beyond the other's arrays is dead: an edit taken back leaves its slots dead).
  static ::testing::AssertionResult same_alive_content(const rpc::MeshDocument& a,
                                                       const rpc::MeshDocument& b) {
    for (std::size_t v = 0; v < std::max(a.positions.size(), b.positions.size()); ++v) {
      const bool in_a = v < a.positions.size() && a.vertex_alive[v];
      const bool in_b = v < b.positions.size() && b.vertex_alive[v];
      if (in_a != in_b || (in_a && a.positions[v] != b.positions[v]))
        return ::testing::AssertionFailure() << "vertex " << v;
    }
    for (std::size_t f = 0; f < std::max(a.faces.size(), b.faces.size()); ++f) {
      const bool in_a = f < a.faces.size() && a.face_alive[f];
      const bool in_b = f < b.faces.size() && b.face_alive[f];
      if (in_a != in_b || (in_a && a.faces[f] != b.faces[f]))
        return ::testing::AssertionFailure() << "face " << f;
    }
    return ::testing::AssertionSuccess();
  }

  testing::FaultyVfs vfs_;  // constructed before SetUp opens the store, gone after TearDown
};

// A failed sync of the journal (SERVICE.md §3.3, "fsync errors are fatal, not retryable"): the
// commit is refused with UNAVAILABLE and the store goes fail-stop. With the disk healthy again
// it still writes nothing (a retried fsync may report success without having flushed what the
// failed one lost), though it still reads; after a restart the journal holds exactly the rows
// acknowledged before the failure.
TEST_F(StoreFaultTest, AFailedSyncMakesTheStoreFailStop) {
  for (std::uint64_t version = 1; version <= 3; ++version)
    ASSERT_TRUE(store_->append_journal(journal_row(version)).is_ok());
  EXPECT_EQ(store_->condition().health, StoreHealth::Ok);
  EXPECT_TRUE(store_->condition().reason.empty());

  vfs_.fail_syncs("touchmend.db-wal");
  const Status failed = store_->append_journal(journal_row(4));
  EXPECT_EQ(failed.code, StatusCode::Unavailable) << failed.to_string();
  EXPECT_NE(failed.message.find("not acknowledged"), std::string::npos) << failed.message;
  EXPECT_GE(vfs_.failures(), 1u);
  EXPECT_EQ(store_->condition().health, StoreHealth::Failed);
  EXPECT_NE(store_->condition().reason.find("journal append"), std::string::npos)
      << store_->condition().reason;

  vfs_.heal();
  const std::uint64_t failures = vfs_.failures();
  const Status refused = store_->append_journal(journal_row(4));
  EXPECT_EQ(refused.code, StatusCode::Unavailable);
  EXPECT_NE(refused.message.find("refused"), std::string::npos) << refused.message;
  EXPECT_EQ(store_->write_snapshot(snapshot_at(3, "S")).code, StatusCode::Unavailable);
  JobRow job;
  job.id = "j1";
  EXPECT_EQ(store_->insert_job(job, "input").code, StatusCode::Unavailable);
  EXPECT_EQ(store_->set_member("s1", "someone", true).code, StatusCode::Unavailable);
  EXPECT_EQ(store_->delete_session("s1").code, StatusCode::Unavailable);
  EXPECT_EQ(vfs_.failures(), failures);  // refused before SQLite was asked
  EXPECT_EQ(versions(*store_), (std::vector<std::uint64_t>{1, 2, 3}));  // reads are served

  store_.reset();
  store_ = open_store();
  ASSERT_TRUE(store_);
  EXPECT_EQ(store_->condition().health, StoreHealth::Ok);
  EXPECT_EQ(versions(*store_), (std::vector<std::uint64_t>{1, 2, 3}));
  EXPECT_TRUE(store_->append_journal(journal_row(4)).is_ok());
}

// A full disk (SERVICE.md §3.3, "Disk full"): writes are refused with RESOURCE_EXHAUSTED and
// counted, the condition says so; once space is back the next write goes through, with no
// restart, and ends the condition. Nothing acknowledged is lost, nothing refused is kept.
TEST_F(StoreFaultTest, AFullDiskRefusesWritesUntilSpaceReturns) {
  for (std::uint64_t version = 1; version <= 2; ++version)
    ASSERT_TRUE(store_->append_journal(journal_row(version, 20'000)).is_ok());
  vfs_.fail_writes_as_full("");
  const Status full = store_->append_journal(journal_row(3, 20'000));
  EXPECT_EQ(full.code, StatusCode::ResourceExhausted) << full.to_string();
  EXPECT_NE(full.message.find("full"), std::string::npos) << full.message;
  EXPECT_EQ(store_->condition().health, StoreHealth::DiskFull);
  JobRow job;
  job.id = "j1";
  EXPECT_EQ(store_->insert_job(job, std::string(10'000, 'x')).code, StatusCode::ResourceExhausted);
  EXPECT_GE(store_->disk_full_refusals(), 2u);
  EXPECT_EQ(versions(*store_), (std::vector<std::uint64_t>{1, 2}));

  vfs_.heal();
  ASSERT_TRUE(store_->append_journal(journal_row(3, 20'000)).is_ok());
  EXPECT_EQ(store_->condition().health, StoreHealth::Ok);
  EXPECT_TRUE(store_->condition().reason.empty());
  store_.reset();
  store_ = open_store();
  ASSERT_TRUE(store_);
  const auto rows = store_->journal_after("s1", 0, 100);
  ASSERT_EQ(rows.size(), 3u);
  for (const JournalRow& row : rows)
    EXPECT_EQ(row.response, journal_row(row.version, 20'000).response) << row.version;
}

// The background checkpoint syncs the database file: when that sync fails, the store goes
// fail-stop as for a failed commit, instead of the checkpointer retrying it silently.
TEST_F(StoreFaultTest, AFailedCheckpointMakesTheStoreFailStop) {
  vfs_.fail_syncs("touchmend.db");  // the database file, not its log
  std::uint64_t version = 0;
  // Past 1,000 pages the checkpointer is asked to copy the log into the database file.
  while (version < 80 && store_->condition().health == StoreHealth::Ok) {
    ++version;
    if (!store_->append_journal(journal_row(version, 100'000)).is_ok()) break;
  }
  for (int wait = 0; wait < 1000 && store_->condition().health == StoreHealth::Ok; ++wait)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  EXPECT_EQ(store_->condition().health, StoreHealth::Failed);
  EXPECT_NE(store_->condition().reason.find("checkpoint"), std::string::npos)
      << store_->condition().reason;
  EXPECT_EQ(store_->append_journal(journal_row(1000)).code, StatusCode::Unavailable);
}

// A session whose journal commit fails: the fill is not applied (the document, its version and
// holes are those before it, nothing is broadcast), later edits and undos are refused with the
// store's reason, and a session recovered after the restart is the one before the failure.
TEST_F(StoreFaultTest, ASessionKeepsNothingItCouldNotJournal) {
  auto session = make_session();
  ASSERT_TRUE(load_sample(*session));
  const auto holes = hole_ids(*session);
  ASSERT_GE(holes.size(), 3u);
  v1::EditResponse first;
  ASSERT_TRUE(fill_one(*session, holes[0], first).is_ok());
  const rpc::MeshDocument before = session->document();
  const auto holes_before = hole_ids(*session);

  vfs_.fail_syncs("touchmend.db-wal");
  v1::EditResponse second;
  const Status failed = fill_one(*session, holes[1], second);
  EXPECT_EQ(failed.code, StatusCode::Unavailable) << failed.to_string();
  EXPECT_EQ(session->version(), before.version);
  EXPECT_TRUE(same_alive_content(session->document(), before));
  EXPECT_EQ(hole_ids(*session), holes_before);
  EXPECT_EQ(session->summary().faces(), before.alive_faces());

  vfs_.heal();
  v1::EditResponse third;
  EXPECT_EQ(fill_one(*session, holes[2], third).code, StatusCode::Unavailable);
  v1::EditResponse undone;
  EXPECT_EQ(session->step_history(Session::History::Undo, "local", undone).code,
            StatusCode::Unavailable);
  EXPECT_EQ(session->version(), before.version);
  EXPECT_EQ(hole_ids(*session), holes_before);

  session.reset();
  store_.reset();
  store_ = open_store();
  ASSERT_TRUE(store_);
  auto recovered = make_session();
  ASSERT_TRUE(recovered->recover().is_ok());
  EXPECT_EQ(recovered->version(), before.version);
  EXPECT_TRUE(same_alive_content(recovered->document(), before));
  EXPECT_EQ(hole_ids(*recovered), holes_before);
  v1::EditResponse again;
  EXPECT_TRUE(fill_one(*recovered, holes[1], again).is_ok());
}

// The store file's write-ahead log is checkpointed by the store's own thread once it passes
// 1,000 pages, not in the commit that takes it there (a journal append waited for that copy);
// every entry is there after a reopen.
TEST_F(SessionTest, TheJournalsLogIsCheckpointedBesideItsCommits) {
  std::mt19937 random(3);
  std::vector<std::string> payloads;
  for (std::uint64_t version = 1; version <= 80; ++version) {
    JournalRow row;
    row.session_id = "s1";
    row.version = version;
    row.kind = JournalKind::Edit;
    row.response.resize(100'000);
    for (char& c : row.response) c = static_cast<char>(random());
    payloads.push_back(row.response);
    ASSERT_TRUE(store_->append_journal(row).is_ok());
  }
  // 8 MB, past 1,000 pages of 4 kB: the checkpointer has been asked at least once.
  for (int wait = 0; wait < 1000 && store_->background_checkpoints() == 0; ++wait)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  EXPECT_GE(store_->background_checkpoints(), 1u);
  store_.reset();
  store_ = open_store();
  const auto rows = store_->journal_after("s1", 0, 1000);
  ASSERT_EQ(rows.size(), payloads.size());
  for (std::size_t i = 0; i < rows.size(); ++i) {
    EXPECT_EQ(rows[i].version, i + 1);
    EXPECT_EQ(rows[i].response, payloads[i]) << "entry " << i + 1;
  }
}

// The edits other than fills, undo and redo (the sharp-edge tool's snap, pushes and finish, a
// sharpen, a stitch, a bridge) keep the session's hole search (updated from what they touched)
// and its search reach, instead of having the next request search the whole mesh again (18 ms at
// 1.37M faces); after each, the holes are those of a cache built from the document, and a fill
// afterwards is the one a rebuilt cache makes.
TEST_F(SessionTest, EditsOtherThanFillsKeepTheHoleSearchTrue) {
  // The cube [0, 8]^3 with holes across its edges x = z = 8 and x = z = 0 and in its face y = 8,
  // and two plates with a gap between them below it.
  geometry::MeshSoup soup = testing::remove_faces(testing::cube(8), [](const geometry::Vec3& c) {
    return (c - geometry::Vec3(8, 4, 8)).norm() < 2.2 ||
           (c - geometry::Vec3(0, 4, 0)).norm() < 2.2 || (c - geometry::Vec3(4, 8, 4)).norm() < 1.8;
  });
  const auto plates_first = static_cast<std::uint32_t>(soup.points.size());
  const geometry::MeshSoup plates = testing::two_plates(4, 0.5);
  for (const auto& p : plates.points) soup.points.push_back(p + geometry::Vec3(0, 0, -20));
  for (const auto& t : plates.triangles)
    soup.triangles.push_back({t[0] + plates_first, t[1] + plates_first, t[2] + plates_first});
  auto session = make_session();
  {
    LoadedMesh loaded;
    ASSERT_TRUE(
        load_document(testing::to_off(soup), geometry::MeshFormat::Off, {}, loaded).is_ok());
    v1::LoadMeshResponse response;
    ASSERT_TRUE(session->load(std::move(loaded), "cube", "local", response).is_ok());
  }
  const auto listing = [](const std::vector<v1::Hole>& holes) {
    std::vector<std::string> out;
    for (const auto& h : holes) out.push_back(h.SerializeAsString());
    return out;
  };
  // After each edit: what was kept, then the holes against a rebuild's.
  const auto counts_right = [&] {
    return session->summary().faces() == session->document().alive_faces() &&
           session->summary().vertices() == session->document().alive_vertices();
  };
  const auto check = [&](const char* edit, bool holes_kept) {
    EXPECT_EQ(session->geometry().mirror_mismatch(session->document()), "") << edit;
    EXPECT_TRUE(counts_right()) << edit;
    EXPECT_TRUE(session->geometry().reach_kept()) << edit;
    EXPECT_EQ(session->geometry().holes_kept(), holes_kept) << edit;
    SessionGeometry rebuilt;
    EXPECT_EQ(listing(session->holes()), listing(rebuilt.holes(session->document()))) << edit;
  };
  const auto point = [](double x, double y, double z) {
    v1::Point3 p;
    p.set_x(x);
    p.set_y(y);
    p.set_z(z);
    return p;
  };
  EXPECT_EQ(session->holes().size(), 5u);  // three on the cube, the plates' borders

  // A faired fill of the hole on x = z = 8 rounds the edge off; the tool brings it back.
  v1::FillHolesRequest fill;
  fill.set_session_id("s1");
  *fill.mutable_selection()->mutable_near() = point(8, 4, 8);
  fill.mutable_options()->set_shape(v1::PATCH_SHAPE_FAIR);
  fill.mutable_options()->set_sharp(v1::SHARP_OFF);
  v1::EditResponse edit;
  ASSERT_TRUE(session->fill(fill, "local", nullptr, edit).is_ok());
  check("fill", true);
  v1::SharpEdgeRequest tool;
  tool.set_session_id("s1");
  for (const double y : {0.5, 2.0, 6.0, 7.5}) *tool.mutable_begin()->add_points() = point(8, y, 8);
  v1::SharpEdgeResponse response;
  ASSERT_TRUE(session->sharp_edge(tool, "local", response).is_ok());
  tool.set_confirm(true);
  ASSERT_TRUE(session->sharp_edge(tool, "local", response).is_ok());
  ASSERT_GT(response.curtain_vertices(), 0u);
  check("snap", true);
  std::size_t pushes = 0;
  for (int round = 0; round < 20; ++round) {
    std::optional<geometry::Vec3> target;
    const rpc::MeshDocument& doc = session->document();
    for (std::size_t v = 0; v < doc.positions.size(); ++v) {
      const auto& p = doc.positions[v];
      if (doc.vertex_alive[v] && std::abs(p[0] - p[2]) < 1e-9 && p[0] > 6 && p[0] < 8 - 1e-9 &&
          p[1] > 2 && p[1] < 6)
        target = geometry::Vec3(p[0], p[1], p[2]);
    }
    if (!target) break;
    v1::SharpEdgeRequest push;
    push.set_session_id("s1");
    *push.mutable_push()->mutable_proxy() = point((*target)[0], (*target)[1], (*target)[2]);
    *push.mutable_push()->mutable_previous() =
        point((*target)[0], (*target)[1] - 0.1, (*target)[2]);
    push.mutable_push()->set_face(0xFFFFFFFFu);
    push.mutable_push()->set_step(0.3);
    ASSERT_TRUE(session->sharp_edge(push, "local", response).is_ok());
    ++pushes;
  }
  EXPECT_GT(pushes, 0u);
  check("pushes", true);
  v1::SharpEdgeRequest smooth;
  smooth.set_session_id("s1");
  smooth.set_smooth(true);
  ASSERT_TRUE(session->sharp_edge(smooth, "local", response).is_ok());
  check("finish", true);

  // The hole on x = z = 0, filled with its crease retained in one request.
  const SessionGeometry::Nearest other = session->nearest_hole(point(0, 4, 0));
  ASSERT_TRUE(other.found);
  v1::SharpenRequest sharpen;
  sharpen.set_session_id("s1");
  sharpen.set_hole_id(other.hole.id());
  for (const double y : {0.5, 2.0, 6.0, 7.5}) *sharpen.add_points() = point(0, y, 0);
  ASSERT_TRUE(session->sharpen(sharpen, "local", edit).is_ok());
  check("sharpen", true);

  // A stitch across the plates' gap: left (4, 0)-(4, 1) to right (0, 0); then a bridge.
  v1::StitchRequest stitch;
  stitch.set_session_id("s1");
  stitch.set_a(plates_first + 4);
  stitch.set_b(plates_first + 9);
  stitch.set_t(plates_first + 25);
  ASSERT_TRUE(session->stitch(stitch, "local", edit).is_ok());
  check("stitch", true);
  v1::BridgeGapsRequest bridge;
  bridge.set_session_id("s1");
  bridge.mutable_ids()->add_ids(0);
  ASSERT_TRUE(session->bridge_gaps(bridge, "local", edit).is_ok()) << edit.summary();
  check("bridge", false);  // a bridge's attempts may relink loops it keeps no face of

  // A fill now is the one a cache built from the document makes.
  const rpc::MeshDocument before = session->document();
  v1::FillHolesRequest rest;
  rest.set_session_id("s1");
  rest.mutable_selection()->set_all(true);
  v1::EditResponse last;
  ASSERT_TRUE(session->fill(rest, "local", nullptr, last).is_ok());
  SessionGeometry rebuilt;
  v1::HoleSelection all;
  all.set_all(true);
  const auto fresh = rebuilt.fill(before, all, {}, {});
  ASSERT_TRUE(fresh.status.is_ok());
  EXPECT_GT(last.delta().added_faces_size(), 0);  // the hole in y = 8
  EXPECT_EQ(last.delta().added_faces_size(), fresh.delta.added_faces_size());
  EXPECT_TRUE(
      std::equal(last.delta().added_positions().begin(), last.delta().added_positions().end(),
                 fresh.delta.added_positions().begin(), fresh.delta.added_positions().end()));
  // Left: the plates' outer border (a flat piece's, left open).
  EXPECT_EQ(session->holes().size(), 1u);

  // Undo it all: the cache follows each inverse delta (the snap's faces changed in place were
  // mapped to its new slots), no rebuild, the holes those of a cache built from the document.
  for (int step = 0; step < 32; ++step) {
    v1::EditResponse undone;
    if (session->step_history(Session::History::Undo, "local", undone).code ==
        StatusCode::FailedPrecondition)
      break;  // nothing left to undo
    ASSERT_EQ(session->geometry().mirror_mismatch(session->document()), "") << "undo " << step;
    ASSERT_TRUE(counts_right()) << "undo " << step;
    SessionGeometry again;
    ASSERT_EQ(listing(session->holes()), listing(again.holes(session->document())))
        << "undo " << step;
  }
  EXPECT_EQ(session->holes().size(), 5u);
}

TEST_F(SessionTest, FillUndoCyclesReuseSlotsAndRecoverIdentically) {
  auto session = make_session();
  ASSERT_TRUE(load_sample(*session));
  const auto holes = hole_ids(*session);
  ASSERT_EQ(holes.size(), 3u);
  const std::size_t loaded_vertices = session->document().positions.size();
  const auto loaded_alive_faces = session->document().alive_faces();

  // Fill A, then many fill/undo cycles (the session mesh cache is garbage-collected along
  // the way) of another hole: slots above A's are reused each time.
  v1::EditResponse a;
  ASSERT_TRUE(fill_one(*session, holes[0], a).is_ok());
  ASSERT_GT(a.delta().added_face_ids_size(), 0);
  const std::size_t after_a = session->document().faces.size();
  std::size_t first_faces = 0, first_vertices = 0;
  for (int cycle = 0; cycle < 200; ++cycle) {  // enough to trigger compactions
    v1::EditResponse b;
    ASSERT_TRUE(fill_one(*session, holes[1], b).is_ok()) << cycle;
    ASSERT_GT(b.delta().added_face_ids_size(), 0);
    // Reused slots: the first new face goes right above A's.
    EXPECT_EQ(b.delta().added_face_ids(0), after_a) << cycle;
    if (cycle == 0) {
      first_faces = session->document().faces.size();
      first_vertices = session->document().positions.size();
    }
    // Bounded: the document never grows beyond the first cycle's size.
    EXPECT_EQ(session->document().faces.size(), first_faces) << cycle;
    EXPECT_EQ(session->document().positions.size(), first_vertices) << cycle;
    v1::EditResponse undone;
    ASSERT_TRUE(session->step_history(Session::History::Undo, "local", undone).is_ok());
  }
  EXPECT_GT(first_vertices, loaded_vertices);
  EXPECT_EQ(hole_ids(*session).size(), 2u);

  // Redo after a reuse cycle, then undo everything: back to the loaded mesh's alive content.
  v1::EditResponse redone;
  ASSERT_TRUE(session->step_history(Session::History::Redo, "local", redone).is_ok());
  EXPECT_EQ(hole_ids(*session).size(), 1u);
  // A new edit after an undo drops the redo stack and may reuse the undone edit's slots; the
  // older edit below it must still undo cleanly.
  v1::EditResponse c;
  ASSERT_TRUE(fill_one(*session, holes[2], c).is_ok());
  EXPECT_TRUE(hole_ids(*session).empty());
  for (int i = 0; i < 3; ++i) {
    v1::EditResponse undone;
    ASSERT_TRUE(session->step_history(Session::History::Undo, "local", undone).is_ok()) << i;
  }
  EXPECT_EQ(hole_ids(*session), holes);
  EXPECT_EQ(session->document().alive_faces(), loaded_alive_faces);
  v1::EditResponse nothing;
  EXPECT_EQ(session->step_history(Session::History::Undo, "local", nothing).code,
            StatusCode::FailedPrecondition);
  v1::EditResponse again;
  ASSERT_TRUE(session->step_history(Session::History::Redo, "local", again).is_ok());

  // Recovery replays the journal (with its reused slots) to the very same document.
  auto recovered = make_session();
  ASSERT_TRUE(recovered->recover().is_ok());
  const rpc::MeshDocument& x = session->document();
  const rpc::MeshDocument& y = recovered->document();
  EXPECT_EQ(x.version, y.version);
  EXPECT_EQ(x.positions, y.positions);
  EXPECT_EQ(x.faces, y.faces);
  EXPECT_EQ(x.vertex_alive, y.vertex_alive);
  EXPECT_EQ(x.face_alive, y.face_alive);
  EXPECT_EQ(hole_ids(*recovered), hole_ids(*session));
  // The summary's counts, kept by both along their edits, are the documents'.
  EXPECT_EQ(session->summary().faces(), x.alive_faces());
  EXPECT_EQ(session->summary().vertices(), x.alive_vertices());
  EXPECT_EQ(recovered->summary().faces(), y.alive_faces());
  EXPECT_EQ(recovered->summary().vertices(), y.alive_vertices());
  // And the recovered history still works: undo the redone fill, fill it again.
  v1::EditResponse undone;
  ASSERT_TRUE(recovered->step_history(Session::History::Undo, "local", undone).is_ok());
  EXPECT_EQ(hole_ids(*recovered), holes);
  v1::EditResponse refill;
  ASSERT_TRUE(fill_one(*recovered, holes[0], refill).is_ok());
  EXPECT_EQ(hole_ids(*recovered).size(), 2u);
}

// An undo or redo sent again with its request_id (its answer was lost, the client reconnected,
// the server restarted) is answered with the step it took, not taken twice (AIP-155).
TEST_F(SessionTest, AnUndoOrRedoSentAgainWithItsRequestIdIsTakenOnce) {
  auto session = make_session();
  ASSERT_TRUE(load_sample(*session));
  const auto holes = hole_ids(*session);
  ASSERT_GE(holes.size(), 2u);
  v1::EditResponse a, b;
  ASSERT_TRUE(fill_one(*session, holes[0], a).is_ok());
  ASSERT_TRUE(fill_one(*session, holes[1], b).is_ok());
  const auto after_fills = hole_ids(*session);

  v1::EditResponse undone, undone_again;
  ASSERT_TRUE(session->step_history(Session::History::Undo, "local", undone, "u-1").is_ok());
  ASSERT_TRUE(session->step_history(Session::History::Undo, "local", undone_again, "u-1").is_ok());
  EXPECT_EQ(undone_again.SerializeAsString(), undone.SerializeAsString());
  EXPECT_EQ(session->version(), b.version() + 1);
  EXPECT_EQ(hole_ids(*session).size(), after_fills.size() + 1);  // only b's hole back

  v1::EditResponse redone, redone_again;
  ASSERT_TRUE(session->step_history(Session::History::Redo, "local", redone, "r-1").is_ok());
  ASSERT_TRUE(session->step_history(Session::History::Redo, "local", redone_again, "r-1").is_ok());
  EXPECT_EQ(redone_again.SerializeAsString(), redone.SerializeAsString());
  EXPECT_EQ(session->version(), b.version() + 2);
  EXPECT_EQ(hole_ids(*session), after_fills);
  // Without an id each call is a step of its own.
  v1::EditResponse plain, plain_again;
  ASSERT_TRUE(session->step_history(Session::History::Undo, "local", plain).is_ok());
  ASSERT_TRUE(session->step_history(Session::History::Undo, "local", plain_again).is_ok());
  EXPECT_EQ(plain_again.version(), plain.version() + 1);
  EXPECT_EQ(hole_ids(*session), holes);

  // The ids are in the journal: after a restart the old ids still answer with their steps.
  auto recovered = make_session();
  ASSERT_TRUE(recovered->recover().is_ok());
  v1::EditResponse replayed;
  ASSERT_TRUE(recovered->step_history(Session::History::Undo, "local", replayed, "u-1").is_ok());
  EXPECT_EQ(replayed.SerializeAsString(), undone.SerializeAsString());
  EXPECT_EQ(recovered->version(), session->version());
  EXPECT_EQ(hole_ids(*recovered), holes);
}

// Recovery from a periodic snapshot, which lives in the snapshot file, and the journal past it:
// the same document and history as the session that wrote them.
TEST_F(SessionTest, RecoversFromAPeriodicSnapshotAndTheJournalPastIt) {
  auto session = make_session();
  ASSERT_TRUE(load_sample(*session));
  const auto holes = hole_ids(*session);
  ASSERT_EQ(holes.size(), 3u);
  v1::EditResponse a, b, undone;
  ASSERT_TRUE(fill_one(*session, holes[0], a).is_ok());
  ASSERT_TRUE(fill_one(*session, holes[1], b).is_ok());
  session->snapshot();  // as the strand does after enough edits, and at shutdown
  const std::uint64_t snapshot_version = session->document().version;
  const auto snap = store_->latest_snapshot("s1");
  ASSERT_TRUE(snap);
  EXPECT_EQ(snap->version, snapshot_version);
  // Past the snapshot: an undo and a fill, journaled only.
  ASSERT_TRUE(session->step_history(Session::History::Undo, "local", undone).is_ok());
  v1::EditResponse c;
  ASSERT_TRUE(fill_one(*session, holes[2], c).is_ok());
  ASSERT_GT(session->document().version, snapshot_version);

  store_.reset();  // as after a restart
  store_ = open_store();
  ASSERT_TRUE(store_);
  auto recovered = make_session();
  ASSERT_TRUE(recovered->recover().is_ok());
  EXPECT_EQ(recovered->document(), session->document());
  EXPECT_EQ(hole_ids(*recovered), hole_ids(*session));
  // The history came back too: the undo of the last fill, then the redo-less older one.
  v1::EditResponse back;
  ASSERT_TRUE(recovered->step_history(Session::History::Undo, "local", back).is_ok());
  EXPECT_EQ(hole_ids(*recovered).size(), 2u);
}

}  // namespace
}  // namespace touchmend::service
