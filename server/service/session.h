#pragma once

//! \file session.h
//! \brief A repair session: the authoritative mesh document, its undo/redo history, its
//! subscribers, and the durable journal behind it.
//!
//! \details Each session is a strand on the worker pool (DESIGN.md "Threading"): every
//! method below runs on strand(), so edits are serialized without locks, and an algorithm
//! running for one session occupies one worker while other sessions go on. An edit is
//! validated, journaled (committed to SQLite) and only then acknowledged and broadcast.

#include <atomic>
#include <boost/asio.hpp>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "proto/rpc/mesh_document.h"
#include "server/service/metrics.h"
#include "server/service/rpc_server.h"
#include "server/service/session_geometry.h"
#include "server/service/store.h"
#include "touchmend/v1/repair.pb.h"

namespace touchmend::service {

struct SessionOptions {
  std::size_t snapshot_every = 64;  //!< journal entries between snapshots (SERVICE.md §7)
  std::size_t max_replay = 10'000;  //!< deltas a subscriber may catch up from the journal
  MeshLimits limits;
};

class Session : public std::enable_shared_from_this<Session> {
 public:
  using Strand = asio::strand<asio::thread_pool::executor_type>;

  Session(SessionRow row, Store& store, asio::thread_pool& pool, Metrics& metrics,
          const SessionOptions& options);

  const std::string& id() const { return row_.id; }
  Strand& strand() { return strand_; }
  //! Thread-safe: owner or member (read under the manager's lock).
  bool allows(const std::string& principal) const;
  const SessionRow& row() const { return row_; }
  void set_member(const std::string& principal, bool present);
  std::uint64_t version() const { return version_.load(std::memory_order_acquire); }
  //! Thread-safe copy of info() as of the last change.
  v1::SessionInfo summary() const;

  // ---- on strand() ----
  Status recover();
  v1::SessionInfo info() const;
  const rpc::MeshDocument& document() const { return document_; }
  //! The session's mesh cache (for tests and diagnostics).
  const SessionGeometry& geometry() const { return geometry_; }
  Status load(LoadedMesh mesh, const std::string& mesh_name, const std::string& principal,
              v1::LoadMeshResponse& response);
  Status fill(const v1::FillHolesRequest& request, const std::string& principal,
              const ServerCall* call, v1::EditResponse& response);
  //! One stitch triangle across a gap (Algorithm VIII); an undoable edit like a fill.
  Status stitch(const v1::StitchRequest& request, const std::string& principal,
                v1::EditResponse& response);
  //! Fills a hole and retains the sharp edge through four picked points; one undoable edit.
  Status sharpen(const v1::SharpenRequest& request, const std::string& principal,
                 v1::EditResponse& response);
  Status list_gaps(const v1::ListGapsRequest& request, v1::ListGapsResponse& response);
  //! Bridges gaps (zipper, or Algorithm IX from two ends); one undoable edit.
  Status bridge_gaps(const v1::BridgeGapsRequest& request, const std::string& principal,
                     v1::EditResponse& response);
  //! The interactive sharp-edge tool (begin, adjust, confirm, push, smooth, cancel).
  Status sharp_edge(const v1::SharpEdgeRequest& request, const std::string& principal,
                    v1::SharpEdgeResponse& response);
  enum class History { Undo, Redo };
  //! Undoes the last edit (journaled as the inverse delta) or redoes the last undone one. A
  //! \p request_id already journaled answers with that step again instead of taking another.
  Status step_history(History direction, const std::string& principal, v1::EditResponse& response,
                      const std::string& request_id = "");
  std::vector<v1::Hole> holes();
  SessionGeometry::Nearest nearest_hole(const v1::Point3& point);
  Status export_mesh(const v1::ExportMeshRequest& request, std::string& bytes);
  //! Sends the deltas after \p after_version (or a resync), then live events.
  Status subscribe(const CallPtr& call, std::uint64_t after_version);
  void unsubscribe(std::uint64_t connection_id, std::uint32_t call_id);
  void publish_presence(const v1::Presence& presence);
  //! Writes a snapshot now (shutdown, close).
  void snapshot();
  //! Ends every subscription (the session was closed).
  void close_subscribers();

 private:
  Status commit(JournalKind kind, std::uint64_t target, v1::EditResponse& response,
                const std::string& principal, const std::string& request_id);
  void broadcast(const v1::SessionEvent& event);
  //! True (and the first answer in \p response) if \p request_id was already journaled.
  bool answered_before(const std::string& request_id, v1::EditResponse& response);
  //! Journals an edit the mesh cache already made (fill, stitch), applies it to the document
  //! and the cache, and makes it undoable.
  Status commit_cache_edit(v1::MeshDelta delta, const std::string& principal,
                           const std::string& request_id, v1::EditResponse& response);
  //! commit_cache_edit for an edit with a report and a one-line summary (sharpen, bridge);
  //! a refused outcome invalidates the cache and is returned.
  Status commit_summarised_edit(SessionGeometry::FillOutcome outcome,
                                const std::string& description, const std::string& summary,
                                const std::string& principal, const std::string& request_id,
                                v1::EditResponse& response);
  SnapshotRow make_snapshot() const;
  void refresh_summary();
  //! Counts the document's alive vertices and faces (after it was replaced); each edit then
  //! adjusts the counts by its delta (counting them per edit read 2 MB at 1.37M faces, twice).
  void count_alive();
  void count_alive(const v1::MeshDelta& applied);
  //! Tells every subscriber what the sharp-edge tool shows now (\p preview's curve, guide and
  //! k), or that it ended (nullptr).
  void publish_tool_preview(const std::string& principal, const v1::SharpEdgeResponse* preview);
  v1::SessionEvent tool_preview_event(const std::string& principal,
                                      const v1::SharpEdgeResponse* preview) const;

  SessionRow row_;
  Store& store_;
  Metrics& metrics_;
  SessionOptions options_;
  Strand strand_;
  rpc::MeshDocument document_;
  SessionGeometry geometry_;
  std::vector<std::uint64_t> undo_;  // versions of Edit entries that can be undone
  std::vector<std::uint64_t> redo_;
  //! Slot extents of the applied history. Edits allocate document slots at the end, and the
  //! history is linear, so every slot an applied edit (or the loaded mesh) created or removed
  //! lies below the extent after it; the dead slots above the current extent belong only to
  //! undone edits, and a new edit (which drops the redo stack) reuses them instead of growing
  //! the document on every fill/undo cycle. undo_extents_[i] goes with undo_[i].
  SlotExtent base_extent_;
  std::vector<SlotExtent> undo_extents_;
  SlotExtent current_extent() const {
    return undo_extents_.empty() ? base_extent_ : undo_extents_.back();
  }
  void push_undo(std::uint64_t version, const v1::MeshDelta& delta);
  void pop_undo();
  void reset_history_extents();
  std::optional<SharpEdgeTool> sharp_tool_;
  std::string sharp_tool_principal_;  //!< who began the open tool
  std::string mesh_name_;
  std::size_t since_snapshot_ = 0;
  std::size_t delta_bytes_since_snapshot_ = 0;
  bool snapshot_queued_ = false;  //!< a snapshot task is posted on the strand
  std::atomic<std::uint64_t> version_{0};
  std::map<std::pair<std::uint64_t, std::uint32_t>, CallPtr> subscribers_;
  mutable std::mutex members_mutex_;
  std::size_t alive_vertices_ = 0;
  std::size_t alive_faces_ = 0;
  mutable std::mutex summary_mutex_;
  v1::SessionInfo summary_;
};

using SessionPtr = std::shared_ptr<Session>;

}  // namespace touchmend::service
