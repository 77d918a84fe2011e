#include "server/service/session.h"

#include <chrono>
#include <cmath>

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
  count_alive();
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

void Session::count_alive() {
  alive_vertices_ = document_.alive_vertices();
  alive_faces_ = document_.alive_faces();
}

void Session::count_alive(const v1::MeshDelta& applied) {
  // apply_delta checked it: a removed element was alive, an added one dead or appended (or
  // removed by the same delta), so each changes the count by one.
  const auto net = [](int added, int removed) {
    return static_cast<std::ptrdiff_t>(added) - removed;
  };
  alive_vertices_ = static_cast<std::size_t>(
      static_cast<std::ptrdiff_t>(alive_vertices_) +
      net(applied.added_vertex_ids_size(), applied.removed_vertices_size()));
  alive_faces_ =
      static_cast<std::size_t>(static_cast<std::ptrdiff_t>(alive_faces_) +
                               net(applied.added_face_ids_size(), applied.removed_faces_size()));
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
  info.set_vertices(alive_vertices_);
  info.set_faces(alive_faces_);
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
  delta_bytes_since_snapshot_ = 0;
}

Status Session::load(LoadedMesh mesh, const std::string& mesh_name, const std::string& principal,
                     v1::LoadMeshResponse& response) {
  rpc::MeshDocument previous = std::move(document_);
  document_ = std::move(mesh.document);
  document_.version = previous.version + 1;
  count_alive();
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
    count_alive();
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
  delta_bytes_since_snapshot_ = 0;
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
             {"vertices", alive_vertices_},
             {"faces", alive_faces_}});
  return {};
}

Status Session::commit(JournalKind kind, std::uint64_t target, v1::EditResponse& response,
                       const std::string& principal, const std::string& request_id) {
  v1::MeshDelta& delta = *response.mutable_delta();
  delta.set_session_id(row_.id);
  delta.set_author(principal);
  // An undo or redo reaches the cache after the document (SessionGeometry::apply), so the cache
  // is still at the delta's base and can tell whether its removed vertices are free.
  const bool removals_checked =
      (kind == JournalKind::Undo || kind == JournalKind::Redo) && geometry_.removals_free(delta);
  if (Status s = rpc::apply_delta(document_, delta, removals_checked); !s.is_ok()) {
    geometry_.invalidate();
    return {StatusCode::Internal, "edit does not apply to the session's mesh: " + s.message};
  }
  count_alive(delta);
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
    count_alive();           // counted again: a rare path, and the inverse is not checked here
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
  // The snapshot is taken as the strand's next task, after this edit has been answered, and
  // only the copy of the document happens there: serialising and writing it (milliseconds for
  // a large mesh) run on the pool beside the strand, so the session's next call does not wait
  // for them (a stream of push-down samples would otherwise see it in its tail).
  // A snapshot costs the document's size, so it waits for as much journal as it saves: 64
  // entries (SERVICE.md §7), and deltas worth the document or 16 x 64 entries (single-vertex
  // push-down samples on a large mesh would otherwise snapshot it every 64). Recovery then reads
  // at most about twice the document. With a quarter of the document, fills on a mesh of 1.37M
  // faces snapshotted it every 190 fills and undos, and the snapshot's copy and its serialising
  // beside the next fills (on the same two cores) were their p99 and max (40 ms against a p50 of
  // 14).
  ++since_snapshot_;
  delta_bytes_since_snapshot_ += delta.ByteSizeLong();
  const std::size_t document_bytes = 24 * document_.positions.size() + 12 * document_.faces.size();
  const bool worth_it = delta_bytes_since_snapshot_ >= document_bytes ||
                        since_snapshot_ >= 16 * options_.snapshot_every;
  if (since_snapshot_ >= options_.snapshot_every && worth_it && !snapshot_queued_) {
    snapshot_queued_ = true;
    asio::post(strand_, [self = shared_from_this()] {
      self->snapshot_queued_ = false;
      if (self->since_snapshot_ == 0) return;
      // A small document is written right here (a few hundred microseconds); handing it to
      // the pool would only have it compete with the session's next edit for the two cores
      // and the store's lock.
      constexpr std::size_t kInlineBytes = 1 << 20;
      if (24 * self->document_.positions.size() + 12 * self->document_.faces.size() <
          kInlineBytes) {
        self->snapshot();
        return;
      }
      auto parts = std::make_shared<std::pair<rpc::MeshDocument, SnapshotRow>>();
      parts->first = self->document_;
      parts->second.session_id = self->row_.id;
      parts->second.version = self->document_.version;
      parts->second.undo = self->undo_;
      parts->second.redo = self->redo_;
      parts->second.mesh_name = self->mesh_name_;
      self->since_snapshot_ = 0;
      self->delta_bytes_since_snapshot_ = 0;
      asio::post(self->strand_.get_inner_executor(), [self, parts] {
        v1::MeshDocument proto;
        rpc::to_proto(parts->first, proto);
        parts->second.document = proto.SerializeAsString();
        if (Status s = self->store_.write_snapshot(parts->second); !s.is_ok()) {
          log_event(spdlog::level::err, "snapshot_failed",
                    {{"session_id", self->row_.id}, {"msg", s.message}});
          // Try again after the next edit.
          asio::post(self->strand_,
                     [self] { self->since_snapshot_ = self->options_.snapshot_every; });
        }
      });
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
    geometry_.discard_pending();  // nothing added; failed attempts are deleted in the cache
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

Status Session::commit_summarised_edit(SessionGeometry::FillOutcome outcome,
                                       const std::string& description, const std::string& summary,
                                       const std::string& principal, const std::string& request_id,
                                       v1::EditResponse& response) {
  if (!outcome.status.is_ok()) {
    geometry_.invalidate();  // a refused attempt may have left deleted elements behind
    return outcome.status;
  }
  outcome.delta.set_description(description);
  *response.mutable_report() = std::move(outcome.report);
  response.set_summary(summary);
  return commit_cache_edit(std::move(outcome.delta), principal, request_id, response);
}

Status Session::sharpen(const v1::SharpenRequest& request, const std::string& principal,
                        v1::EditResponse& response) {
  if (answered_before(request.request_id(), response)) return {};
  if (document_.faces.empty())
    return {StatusCode::FailedPrecondition, "the session has no mesh loaded"};
  std::string summary;
  SessionGeometry::FillOutcome outcome =
      geometry_.sharpen(document_, request, current_extent(), summary);
  return commit_summarised_edit(std::move(outcome),
                                "sharpen hole " + std::to_string(request.hole_id()), summary,
                                principal, request.request_id(), response);
}

Status Session::list_gaps(const v1::ListGapsRequest& request, v1::ListGapsResponse& response) {
  if (!(request.max_width() >= 0) || !std::isfinite(request.max_width()))
    return {StatusCode::InvalidArgument, "max_width must be finite and >= 0"};
  response.set_version(document_.version);
  if (document_.faces.empty()) return {};
  for (const auto& gap : geometry_.gaps(document_, request.max_width()))
    *response.add_gaps() = geometry_.gap_to_proto(gap);
  return {};
}

Status Session::bridge_gaps(const v1::BridgeGapsRequest& request, const std::string& principal,
                            v1::EditResponse& response) {
  if (answered_before(request.request_id(), response)) return {};
  if (document_.faces.empty())
    return {StatusCode::FailedPrecondition, "the session has no mesh loaded"};
  std::string summary;
  SessionGeometry::FillOutcome outcome =
      geometry_.bridge(document_, request, current_extent(), summary);
  return commit_summarised_edit(std::move(outcome), "bridge gaps", summary, principal,
                                request.request_id(), response);
}

namespace {

void fill_preview(const SharpEdgeTool& tool, v1::SharpEdgeResponse& response) {
  const auto guide = tool.guide();
  if (!guide) return;
  const auto point = [](const geometry::Vec3& p) {
    v1::Point3 q;
    q.set_x(p[0]);
    q.set_y(p[1]);
    q.set_z(p[2]);
    return q;
  };
  for (const auto& s : guide->samples) *response.add_curve() = point(s.point);
  for (const auto& t : guide->triangles())
    for (const auto& p : t) *response.add_guide() = point(p);
  response.set_patch_faces(static_cast<std::uint32_t>(tool.patch_faces.size()));
  response.set_curtain_vertices(static_cast<std::uint32_t>(tool.on_guide.size()));
  response.set_crease_tangent_start(tool.crease_tangent_start);
  response.set_crease_tangent_end(tool.crease_tangent_end);
}

}  // namespace

Status Session::sharp_edge(const v1::SharpEdgeRequest& request, const std::string& principal,
                           v1::SharpEdgeResponse& response) {
  if (document_.faces.empty())
    return {StatusCode::FailedPrecondition, "the session has no mesh loaded"};
  const auto edit = [&](SessionGeometry::FillOutcome outcome,
                        const std::string& description) -> Status {
    if (!outcome.status.is_ok()) {
      geometry_.invalidate();
      return outcome.status;
    }
    outcome.delta.set_description(description);
    v1::EditResponse committed;
    if (Status s =
            commit_cache_edit(std::move(outcome.delta), principal, request.request_id(), committed);
        !s.is_ok())
      return s;
    response.set_version(committed.version());
    *response.mutable_delta() = committed.delta();
    return {};
  };
  switch (request.action_case()) {
    case v1::SharpEdgeRequest::kBegin: {
      SharpEdgeTool tool;
      if (Status s = geometry_.sharp_edge_begin(document_, base_extent_, request.begin(), tool);
          !s.is_ok())
        return s;
      sharp_tool_ = std::move(tool);
      sharp_tool_principal_ = principal;
      response.set_version(document_.version);
      response.set_summary("sharp-edge tool on a patch of " +
                           std::to_string(sharp_tool_->patch_faces.size()) + " faces; " +
                           geometry::tangents_summary(sharp_tool_->crease_tangent_start,
                                                      sharp_tool_->crease_tangent_end,
                                                      sharp_tool_->tangents));
      break;
    }
    case v1::SharpEdgeRequest::kAdjust: {
      if (!sharp_tool_) return {StatusCode::FailedPrecondition, "no sharp-edge tool: begin first"};
      if (sharp_tool_->snapped)
        return {StatusCode::FailedPrecondition,
                "the curve is fixed once the patch is snapped onto it (cancel and begin again)"};
      const auto& a = request.adjust();
      if (!(a.k1() >= 0) || !(a.k4() >= 0) || !std::isfinite(a.k1() + a.k4()))
        return {StatusCode::InvalidArgument, "k1 and k4 must be finite and >= 0"};
      sharp_tool_->k1 = a.k1();
      sharp_tool_->k4 = a.k4();
      response.set_version(document_.version);
      break;
    }
    case v1::SharpEdgeRequest::kConfirm: {
      if (!sharp_tool_) return {StatusCode::FailedPrecondition, "no sharp-edge tool: begin first"};
      if (sharp_tool_->snapped) return {StatusCode::FailedPrecondition, "already snapped"};
      SharpEdgeTool tool = *sharp_tool_;
      if (Status s = edit(geometry_.sharp_edge_snap(document_, tool, current_extent()),
                          "sharp edge: snap onto the guiding surface");
          !s.is_ok())
        return s;
      sharp_tool_ = std::move(tool);
      response.set_summary(std::to_string(sharp_tool_->on_guide.size()) +
                           " vertices on the guiding surface");
      break;
    }
    case v1::SharpEdgeRequest::kPush: {
      if (!sharp_tool_ || !sharp_tool_->snapped)
        return {StatusCode::FailedPrecondition, "confirm the curve before pushing"};
      SharpEdgeTool tool = *sharp_tool_;
      SessionGeometry::PushReport report;
      const Status s = edit(geometry_.sharp_edge_push(document_, tool, request.push(), report),
                            "sharp edge: push");
      response.set_at_limit(report.at_limit);
      response.set_push_samples(report.samples);
      if (!s.is_ok()) return s;
      sharp_tool_ = std::move(tool);
      break;
    }
    case v1::SharpEdgeRequest::kSmooth: {
      if (!sharp_tool_ || !sharp_tool_->snapped)
        return {StatusCode::FailedPrecondition, "confirm the curve before smoothing"};
      geometry::PushFinish finish;
      if (!to_push_finish(request.finish(), finish))
        return {StatusCode::InvalidArgument, "unknown finish " + std::to_string(request.finish())};
      SharpEdgeTool tool = *sharp_tool_;
      if (Status s = edit(geometry_.sharp_edge_smooth(document_, tool, finish),
                          std::string("sharp edge: finish (") + geometry::to_string(finish) + ")");
          !s.is_ok())
        return s;
      fill_preview(tool, response);
      sharp_tool_.reset();  // the edit is finished
      response.set_summary(std::string("patch finished (") + geometry::to_string(finish) +
                           "): the sharp-edge tool is done");
      publish_tool_preview(principal, nullptr);
      return {};
    }
    case v1::SharpEdgeRequest::kCancel:
      sharp_tool_.reset();
      response.set_version(document_.version);
      response.set_summary("sharp-edge tool cancelled");
      publish_tool_preview(principal, nullptr);
      return {};
    default:
      return {StatusCode::InvalidArgument,
              "no action (begin, adjust, confirm, push, smooth, cancel)"};
  }
  const auto [k1, k4] = sharp_tool_->effective_k();
  response.set_k1(k1);
  response.set_k4(k4);
  fill_preview(*sharp_tool_, response);
  // Pushes move single vertices (their deltas say it all); the curve changes on the others.
  if (request.action_case() != v1::SharpEdgeRequest::kPush)
    publish_tool_preview(principal, &response);
  return {};
}

v1::SessionEvent Session::tool_preview_event(const std::string& principal,
                                             const v1::SharpEdgeResponse* preview) const {
  v1::SessionEvent event;
  v1::ToolPreview& tool = *event.mutable_tool_preview();
  tool.set_principal(principal);
  tool.set_active(preview != nullptr);
  if (preview) {
    const bool snapped = sharp_tool_ && sharp_tool_->snapped;
    *tool.mutable_curve() = preview->curve();
    if (!snapped) *tool.mutable_guide() = preview->guide();  // drawn until the snap
    tool.set_k1(preview->k1());
    tool.set_k4(preview->k4());
    tool.set_snapped(snapped);
  }
  return event;
}

void Session::publish_tool_preview(const std::string& principal,
                                   const v1::SharpEdgeResponse* preview) {
  broadcast(tool_preview_event(principal, preview));
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
                             v1::EditResponse& response, const std::string& request_id) {
  if (answered_before(request_id, response)) return {};
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
  if (Status s = commit(kind, target, response, principal, request_id); !s.is_ok()) {
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
  // A client joining while someone's sharp-edge tool is open sees its preview at once.
  if (sharp_tool_) {
    v1::SharpEdgeResponse preview;
    const auto [k1, k4] = sharp_tool_->effective_k();
    preview.set_k1(k1);
    preview.set_k4(k4);
    fill_preview(*sharp_tool_, preview);
    call->send(tool_preview_event(sharp_tool_principal_, &preview).SerializeAsString());
  }
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
