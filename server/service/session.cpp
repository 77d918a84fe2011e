#include "server/service/session.h"

#include <chrono>

#include "server/service/log.h"

namespace touchmend::service {

namespace {
bool delta_is_empty(const v1::MeshDelta& d) {
  return d.removed_faces_size() == 0 && d.removed_vertices_size() == 0 &&
         d.added_vertex_ids_size() == 0 && d.moved_vertex_ids_size() == 0 &&
         d.added_face_ids_size() == 0;
}
}  // namespace

Session::Session(SessionRow row, Store& store, asio::thread_pool& pool, Metrics& metrics,
                 const SessionOptions& options)
    : row_(std::move(row)),
      store_(store),
      metrics_(metrics),
      options_(options),
      strand_(asio::make_strand(pool.get_executor())) {}

bool Session::allows(const std::string& principal) const {
  std::lock_guard lock(members_mutex_);
  if (principal == row_.owner) return true;
  for (const auto& m : row_.members) {
    if (m == principal) return true;
  }
  return false;
}

void Session::set_member(const std::string& principal, bool present) {
  std::lock_guard lock(members_mutex_);
  auto it = std::find(row_.members.begin(), row_.members.end(), principal);
  if (present && it == row_.members.end()) row_.members.push_back(principal);
  if (!present && it != row_.members.end()) row_.members.erase(it);
}

void Session::reset_history_extents() {
  base_extent_ = {static_cast<std::uint32_t>(document_.positions.size()),
                  static_cast<std::uint32_t>(document_.faces.size())};
  undo_extents_.clear();
}

void Session::push_undo(std::uint64_t version, const v1::MeshDelta& delta) {
  SlotExtent extent = current_extent();
  const auto cover = [](std::uint32_t& bound, std::uint32_t id) {
    bound = std::max(bound, id + 1);
  };
  for (const std::uint32_t v : delta.added_vertex_ids()) cover(extent.vertices, v);
  for (const std::uint32_t v : delta.removed_vertices()) cover(extent.vertices, v);
  for (const std::uint32_t v : delta.moved_vertex_ids()) cover(extent.vertices, v);
  for (const std::uint32_t f : delta.added_face_ids()) cover(extent.faces, f);
  for (const std::uint32_t f : delta.removed_faces()) cover(extent.faces, f);
  undo_.push_back(version);
  undo_extents_.push_back(extent);
}

void Session::pop_undo() {
  if (undo_.empty()) return;
  undo_.pop_back();
  undo_extents_.pop_back();
}

Status Session::recover() {
  if (auto snap = store_.latest_snapshot(row_.id)) {
    v1::MeshDocument proto;
    if (!proto.ParseFromString(snap->document)) {
      return {StatusCode::DataLoss, "snapshot " + std::to_string(snap->version) + " of session " +
                                        row_.id + " does not parse"};
    }
    if (Status s = rpc::from_proto(proto, document_); !s.is_ok()) {
      return {StatusCode::DataLoss, "snapshot of session " + row_.id + ": " + s.message};
    }
    document_.version = snap->version;
    undo_ = snap->undo;
    redo_ = snap->redo;
    mesh_name_ = snap->mesh_name;
  }
  // The snapshot does not record the history's slot extents: take the whole document for each
  // (conservative: no slot of the restored history is ever reused).
  reset_history_extents();
  undo_extents_.assign(undo_.size(), base_extent_);
  for (;;) {
    auto rows = store_.journal_after(row_.id, document_.version, 1000);
    if (rows.empty()) break;
    for (const auto& row : rows) {
      v1::EditResponse response;
      if (!response.ParseFromString(row.response)) {
        return {StatusCode::DataLoss, "journal entry " + std::to_string(row.version) +
                                          " of session " + row_.id + " does not parse"};
      }
      if (row.kind == JournalKind::Load) {
        return {StatusCode::DataLoss, "journal load entry " + std::to_string(row.version) +
                                          " of session " + row_.id + " has no snapshot"};
      }
      if (Status s = rpc::apply_delta(document_, response.delta()); !s.is_ok()) {
        return {StatusCode::DataLoss, "journal entry " + std::to_string(row.version) +
                                          " of session " + row_.id + ": " + s.message};
      }
      switch (row.kind) {
        case JournalKind::Edit:
          push_undo(row.version, response.delta());
          redo_.clear();
          break;
        case JournalKind::Undo:
          pop_undo();
          redo_.push_back(row.target);
          break;
        case JournalKind::Redo:
          if (!redo_.empty()) redo_.pop_back();
          push_undo(row.target, response.delta());
          break;
        default:
          break;
      }
      ++since_snapshot_;
    }
  }
  version_.store(document_.version, std::memory_order_release);
  geometry_.invalidate();
  refresh_summary();
  return {};
}

v1::SessionInfo Session::summary() const {
  std::lock_guard lock(summary_mutex_);
  v1::SessionInfo copy = summary_;
  if (copy.session_id().empty()) {
    copy.set_session_id(row_.id);
    copy.set_name(row_.name);
    copy.set_owner(row_.owner);
    copy.set_created_unix_ms(row_.created_ms);
  }
  return copy;
}

void Session::refresh_summary() {
  v1::SessionInfo fresh = info();
  std::lock_guard lock(summary_mutex_);
  summary_ = std::move(fresh);
}

v1::SessionInfo Session::info() const {
  v1::SessionInfo info;
  info.set_session_id(row_.id);
  info.set_name(row_.name);
  info.set_owner(row_.owner);
  {
    std::lock_guard lock(members_mutex_);
    for (const auto& m : row_.members) info.add_members(m);
  }
  info.set_version(document_.version);
  info.set_vertices(document_.alive_vertices());
  info.set_faces(document_.alive_faces());
  info.set_mesh_name(mesh_name_);
  info.set_undo_depth(static_cast<std::uint32_t>(undo_.size()));
  info.set_redo_depth(static_cast<std::uint32_t>(redo_.size()));
  info.set_created_unix_ms(row_.created_ms);
  return info;
}

SnapshotRow Session::make_snapshot() const {
  SnapshotRow snap;
  snap.session_id = row_.id;
  snap.version = document_.version;
  v1::MeshDocument proto;
  rpc::to_proto(document_, proto);
  snap.document = proto.SerializeAsString();
  snap.undo = undo_;
  snap.redo = redo_;
  snap.mesh_name = mesh_name_;
  return snap;
}

void Session::snapshot() {
  if (since_snapshot_ == 0) return;
  if (Status s = store_.write_snapshot(make_snapshot()); !s.is_ok()) {
    log_event(spdlog::level::err, "snapshot_failed", {{"session_id", row_.id}, {"msg", s.message}});
    return;
  }
  since_snapshot_ = 0;
}

Status Session::load(LoadedMesh mesh, const std::string& mesh_name, const std::string& principal,
                     v1::LoadMeshResponse& response) {
  rpc::MeshDocument previous = std::move(document_);
  document_ = std::move(mesh.document);
  document_.version = previous.version + 1;
  const std::string previous_name = mesh_name_;
  mesh_name_ = mesh_name;
  auto previous_undo = std::move(undo_);
  auto previous_redo = std::move(redo_);
  const SlotExtent previous_base = base_extent_;
  auto previous_extents = std::move(undo_extents_);
  undo_.clear();
  redo_.clear();
  reset_history_extents();
  // A load is journaled with a snapshot of the new mesh in one transaction.
  JournalRow row;
  row.session_id = row_.id;
  row.version = document_.version;
  row.kind = JournalKind::Load;
  row.mesh_name = mesh_name;
  v1::EditResponse record;
  record.set_version(document_.version);
  record.mutable_delta()->set_session_id(row_.id);
  record.mutable_delta()->set_base_version(previous.version);
  record.mutable_delta()->set_version(document_.version);
  record.mutable_delta()->set_description("load " + mesh_name);
  record.mutable_delta()->set_author(principal);
  row.response = record.SerializeAsString();
  const SnapshotRow snap = make_snapshot();
  const auto start = std::chrono::steady_clock::now();
  if (Status s = store_.append_journal(row, &snap); !s.is_ok()) {
    document_ = std::move(previous);
    mesh_name_ = previous_name;
    undo_ = std::move(previous_undo);
    redo_ = std::move(previous_redo);
    base_extent_ = previous_base;
    undo_extents_ = std::move(previous_extents);
    return s;
  }
  metrics_.journal_commit.observe(
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  since_snapshot_ = 0;
  version_.store(document_.version, std::memory_order_release);
  geometry_.invalidate();
  refresh_summary();
  *response.mutable_session() = info();
  to_proto(mesh.validation, *response.mutable_validation());
  v1::SessionEvent event;
  event.mutable_resync()->set_version(document_.version);
  event.mutable_resync()->set_reason("a new mesh was loaded (" + mesh_name + ")");
  broadcast(event);
  log_event(spdlog::level::info, "mesh_loaded",
            {{"session_id", row_.id},
             {"principal", principal},
             {"mesh", mesh_name},
             {"vertices", document_.alive_vertices()},
             {"faces", document_.alive_faces()}});
  return {};
}

Status Session::commit(JournalKind kind, std::uint64_t target, v1::EditResponse& response,
                       const std::string& principal, const std::string& request_id) {
  v1::MeshDelta& delta = *response.mutable_delta();
  delta.set_session_id(row_.id);
  delta.set_author(principal);
  if (Status s = rpc::apply_delta(document_, delta); !s.is_ok()) {
    geometry_.invalidate();
    return {StatusCode::Internal, "edit does not apply to the session's mesh: " + s.message};
  }
  response.set_version(document_.version);
  JournalRow row;
  row.session_id = row_.id;
  row.version = document_.version;
  row.kind = kind;
  row.target = target;
  row.request_id = request_id;
  row.response = response.SerializeAsString();
  const auto start = std::chrono::steady_clock::now();
  if (Status s = store_.append_journal(row); !s.is_ok()) {
    // Not durable, so not applied: take the edit back.
    const v1::MeshDelta inverse = rpc::invert_delta(delta, document_);
    rpc::MeshDocument& doc = document_;
    (void)rpc::apply_delta(doc, inverse);
    document_.version -= 2;  // inverse bumped it once more; the edit never happened
    geometry_.invalidate();
    log_event(spdlog::level::err, "journal_failed", {{"session_id", row_.id}, {"msg", s.message}});
    return s;
  }
  metrics_.journal_commit.observe(
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  version_.store(document_.version, std::memory_order_release);
  refresh_summary();
  v1::SessionEvent event;
  *event.mutable_delta() = delta;
  broadcast(event);
  // The snapshot runs as the strand's next task, after this edit has been answered: it is
  // not part of any edit's latency (only the session's next call may wait for it).
  if (++since_snapshot_ >= options_.snapshot_every && !snapshot_queued_) {
    snapshot_queued_ = true;
    asio::post(strand_, [self = shared_from_this()] {
      self->snapshot_queued_ = false;
      self->snapshot();
    });
  }
  return {};
}

Status Session::fill(const v1::FillHolesRequest& request, const std::string& principal,
                     const ServerCall* call, v1::EditResponse& response) {
  if (answered_before(request.request_id(), response)) return {};
  if (document_.faces.empty())
    return {StatusCode::FailedPrecondition, "the session has no mesh loaded"};
  SessionGeometry::FillOutcome outcome = geometry_.fill(
      document_, request.selection(), request.options(),
      [call](std::size_t, std::size_t) { return call == nullptr || !call->cancelled(); },
      current_extent());
  if (!outcome.status.is_ok()) return outcome.status;
  if (call != nullptr && call->cancelled()) {
    geometry_.invalidate();
    return {StatusCode::Cancelled, "cancelled"};
  }
  *response.mutable_report() = outcome.report;
  if (delta_is_empty(outcome.delta)) {
    geometry_.commit_pending();  // nothing added; failed attempts are deleted in the cache
    geometry_.invalidate();
    response.set_version(document_.version);
    return {};
  }
  std::string description = "fill holes";
  for (const auto& h : outcome.report.holes()) {
    if (h.filled()) description += " " + std::to_string(h.hole_id());
  }
  outcome.delta.set_description(description);
  return commit_cache_edit(std::move(outcome.delta), principal, request.request_id(), response);
}

Status Session::stitch(const v1::StitchRequest& request, const std::string& principal,
                       v1::EditResponse& response) {
  if (answered_before(request.request_id(), response)) return {};
  if (document_.faces.empty())
    return {StatusCode::FailedPrecondition, "the session has no mesh loaded"};
  SessionGeometry::FillOutcome outcome =
      geometry_.stitch(document_, request.a(), request.b(), request.t(), current_extent());
  if (!outcome.status.is_ok()) return outcome.status;
  outcome.delta.set_description("stitch " + std::to_string(request.a()) + "-" +
                                std::to_string(request.b()) + " to " + std::to_string(request.t()));
  return commit_cache_edit(std::move(outcome.delta), principal, request.request_id(), response);
}

bool Session::answered_before(const std::string& request_id, v1::EditResponse& response) {
  if (request_id.empty()) return false;
  auto done = store_.journal_by_request(row_.id, request_id);
  if (!done) return false;
  response.ParseFromString(done->response);  // the same answer as the first time
  return true;
}

Status Session::commit_cache_edit(v1::MeshDelta delta, const std::string& principal,
                                  const std::string& request_id, v1::EditResponse& response) {
  *response.mutable_delta() = std::move(delta);
  if (Status s = commit(JournalKind::Edit, 0, response, principal, request_id); !s.is_ok()) {
    geometry_.invalidate();
    return s;
  }
  geometry_.commit_pending();
  push_undo(document_.version, response.delta());
  redo_.clear();
  refresh_summary();
  return {};
}

Status Session::step_history(History direction, const std::string& principal,
                             v1::EditResponse& response) {
  const bool undoing = direction == History::Undo;
  const std::vector<std::uint64_t>& from = undoing ? undo_ : redo_;
  if (from.empty())
    return {StatusCode::FailedPrecondition, undoing ? "nothing to undo" : "nothing to redo"};
  const std::uint64_t target = from.back();
  auto entry = store_.journal_entry(row_.id, target);
  v1::EditResponse original;
  if (!entry || !original.ParseFromString(entry->response)) {
    return {StatusCode::DataLoss, "journal entry " + std::to_string(target) + " is missing"};
  }
  // Undo applies the inverse of the edit; redo applies the edit again on the current version.
  *response.mutable_delta() = undoing ? rpc::invert_delta(original.delta(), document_)
                                      : rpc::rebase_delta(original.delta(), document_.version);
  response.mutable_delta()->set_description((undoing ? "undo " : "redo ") + std::to_string(target));
  const JournalKind kind = undoing ? JournalKind::Undo : JournalKind::Redo;
  if (Status s = commit(kind, target, response, principal, ""); !s.is_ok()) {
    geometry_.invalidate();
    return s;
  }
  geometry_.apply(response.delta());
  if (undoing) {
    pop_undo();
    redo_.push_back(target);
  } else {
    redo_.pop_back();
    push_undo(target, response.delta());
  }
  refresh_summary();
  return {};
}

std::vector<v1::Hole> Session::holes() {
  return geometry_.holes(document_);
}

SessionGeometry::Nearest Session::nearest_hole(const v1::Point3& point) {
  return geometry_.nearest_hole(document_, point);
}

Status Session::export_mesh(const v1::ExportMeshRequest& request, std::string& bytes) {
  if (request.format() == v1::DOCUMENT) {
    v1::MeshDocument proto;
    rpc::to_proto(document_, proto);
    bytes = proto.SerializeAsString();
    return {};
  }
  geometry::MeshFormat format;
  if (!to_geometry_format(request.format(), format)) {
    return {StatusCode::InvalidArgument, "unknown export format"};
  }
  if (document_.faces.empty())
    return {StatusCode::FailedPrecondition, "the session has no mesh loaded"};
  return export_document(document_, format, request.binary(), bytes);
}

Status Session::subscribe(const CallPtr& call, std::uint64_t after_version) {
  if (after_version > document_.version) {
    return {StatusCode::OutOfRange, "version " + std::to_string(after_version) +
                                        " is ahead of the session (" +
                                        std::to_string(document_.version) + ")"};
  }
  if (after_version < document_.version) {
    bool replayable = document_.version - after_version <= options_.max_replay;
    std::vector<JournalRow> rows;
    if (replayable) rows = store_.journal_after(row_.id, after_version, options_.max_replay);
    std::uint64_t expected = after_version + 1;
    for (const auto& r : rows) {
      if (r.version != expected++ || r.kind == JournalKind::Load) replayable = false;
    }
    if (!replayable || rows.empty()) {
      v1::SessionEvent event;
      event.mutable_resync()->set_version(document_.version);
      event.mutable_resync()->set_reason("the journal cannot replay from version " +
                                         std::to_string(after_version));
      call->send(event.SerializeAsString());
    } else {
      for (const auto& r : rows) {
        v1::EditResponse response;
        response.ParseFromString(r.response);
        v1::SessionEvent event;
        *event.mutable_delta() = response.delta();
        call->send(event.SerializeAsString());
      }
    }
  }
  std::weak_ptr<Session> weak = weak_from_this();
  call->make_resync = [weak] {
    v1::SessionEvent event;
    if (auto s = weak.lock()) event.mutable_resync()->set_version(s->version());
    event.mutable_resync()->set_reason("events were dropped: the client read too slowly");
    return event.SerializeAsString();
  };
  subscribers_[{call->connection_id(), call->id()}] = call;
  return {};
}

void Session::unsubscribe(std::uint64_t connection_id, std::uint32_t call_id) {
  subscribers_.erase({connection_id, call_id});
}

void Session::broadcast(const v1::SessionEvent& event) {
  const std::string bytes = event.SerializeAsString();
  for (auto it = subscribers_.begin(); it != subscribers_.end();) {
    if (it->second->finished()) {
      it = subscribers_.erase(it);
      continue;
    }
    it->second->send_droppable(bytes);
    ++it;
  }
}

void Session::publish_presence(const v1::Presence& presence) {
  v1::SessionEvent event;
  *event.mutable_presence() = presence;
  broadcast(event);
}

void Session::close_subscribers() {
  v1::SessionEvent event;
  *event.mutable_closed() = info();
  const std::string bytes = event.SerializeAsString();
  for (auto& [key, call] : subscribers_) call->finish({}, bytes);
  subscribers_.clear();
}

}  // namespace touchmend::service
