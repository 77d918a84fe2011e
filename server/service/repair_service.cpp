#include "server/service/repair_service.h"

#include <cmath>
#include <fstream>
#include <future>

#include "server/service/log.h"

namespace touchmend::service {

namespace {

template <class Message>
void reply(const CallPtr& call, const Status& status, const Message& message) {
  if (status.is_ok()) {
    call->finish({}, message.SerializeAsString());
  } else {
    call->finish(status);
  }
}

//! A unary call: exactly one request message, then end of stream; \p handler gets it parsed.
template <class Request, class Fn>
void unary(const CallPtr& call, Fn handler) {
  auto request = std::make_shared<Request>();
  auto received = std::make_shared<bool>(false);
  call->on_message = [call, request, received](std::string_view payload) {
    if (*received) {
      call->finish({StatusCode::InvalidArgument, "a unary call takes exactly one message"});
      return;
    }
    *received = true;
    if (!request->ParseFromArray(payload.data(), static_cast<int>(payload.size()))) {
      call->finish(
          {StatusCode::InvalidArgument,
           "the request is not a valid " + std::string(Request::descriptor()->full_name())});
    }
  };
  call->on_half_close = [call, request, received, handler]() mutable {
    if (call->finished()) return;
    if (!*received) {
      call->finish({StatusCode::InvalidArgument, "no request message"});
      return;
    }
    handler(*request);
  };
}

//! A client stream of chunks (UploadMesh, SubmitFillJob): the first chunk carries a header
//! that \p accept_first checks and that declares the total size; the data is accumulated up
//! to exactly that size (at most \p limit), and \p complete runs at the end of the stream.
//! A stream cut off early, too long, or not parsing is answered with INVALID_ARGUMENT.
template <class Chunk>
void chunked_upload(
    const CallPtr& call, std::size_t limit,
    std::function<Status(const Chunk& first, std::uint64_t& declared)> accept_first,
    std::function<void(const Chunk& first, std::shared_ptr<std::string> bytes)> complete) {
  struct State {
    bool have_first = false;
    Chunk first;
    std::uint64_t declared = 0;
    std::shared_ptr<std::string> bytes = std::make_shared<std::string>();
  };
  auto state = std::make_shared<State>();
  call->on_message = [call, state, limit, accept_first](std::string_view payload) {
    if (call->finished()) return;
    Chunk chunk;
    if (!chunk.ParseFromArray(payload.data(), static_cast<int>(payload.size()))) {
      call->finish({StatusCode::InvalidArgument,
                    "a message is not a valid " + std::string(Chunk::descriptor()->full_name())});
      return;
    }
    if (!state->have_first) {
      std::uint64_t declared = 0;
      if (Status s = accept_first(chunk, declared); !s.is_ok()) {
        call->finish(s);
        return;
      }
      if (declared == 0) {
        call->finish(
            {StatusCode::InvalidArgument, "total_bytes must be the size of the mesh file"});
        return;
      }
      if (declared > limit) {
        call->finish({StatusCode::ResourceExhausted, "upload of " + std::to_string(declared) +
                                                         " bytes exceeds the limit of " +
                                                         std::to_string(limit)});
        return;
      }
      state->declared = declared;
      state->have_first = true;
      state->first = chunk;
      state->first.clear_data();
    }
    if (state->bytes->size() + chunk.data().size() > state->declared) {
      call->finish(
          {StatusCode::InvalidArgument, "the upload is longer than its declared total_bytes"});
      return;
    }
    state->bytes->append(chunk.data());
  };
  call->on_half_close = [call, state, complete] {
    if (call->finished()) return;
    if (!state->have_first) {
      call->finish({StatusCode::InvalidArgument, "empty upload"});
      return;
    }
    if (state->bytes->size() != state->declared) {
      call->finish({StatusCode::InvalidArgument, "upload cut off: received " +
                                                     std::to_string(state->bytes->size()) + " of " +
                                                     std::to_string(state->declared) + " bytes"});
      return;
    }
    complete(state->first, state->bytes);
  };
  call->on_cancel = [state] { state->bytes->clear(); };
}

bool finite(const v1::Point3& p) {
  return std::isfinite(p.x()) && std::isfinite(p.y()) && std::isfinite(p.z());
}

//! Streams \p bytes as MeshChunk messages of 64 KiB, pulled as the connection drains.
void stream_chunks(const CallPtr& call, std::shared_ptr<const std::string> bytes) {
  auto offset = std::make_shared<std::size_t>(0);
  call->set_producer([call, bytes, offset]() -> std::optional<std::string> {
    if (*offset >= bytes->size() && *offset != 0) {
      call->finish({});
      return std::nullopt;
    }
    const std::size_t n = std::min(rpc::kChunkBytes, bytes->size() - *offset);
    v1::MeshChunk chunk;
    chunk.set_data(bytes->substr(*offset, n));
    *offset += n;
    if (n == 0) *offset = 1;  // an empty payload still yields one chunk, then the end
    return chunk.SerializeAsString();
  });
}

}  // namespace

template <class Request, class Work>
void RepairService::on_session(const CallPtr& call, Work work) {
  unary<Request>(call, [this, call, work](const Request& req) {
    SessionPtr session;
    if (Status s = open_session(call->principal(), req.session_id(), session); !s.is_ok()) {
      call->finish(s);
      return;
    }
    asio::post(session->strand(), [call, session, req, work] {
      if (!call->cancelled()) work(req, session);
    });
  });
}

RepairService::RepairService(Store& store, JobManager& jobs, asio::thread_pool& pool,
                             Metrics& metrics, ServiceOptions options)
    : store_(store), jobs_(jobs), pool_(pool), metrics_(metrics), options_(std::move(options)) {
  handlers_ = {
      {"Health", &RepairService::health},
      {"CreateSession", &RepairService::create_session},
      {"ListSessions", &RepairService::list_sessions},
      {"OpenSession", &RepairService::open_session_rpc},
      {"ShareSession", &RepairService::share_session},
      {"CloseSession", &RepairService::close_session},
      {"UploadMesh", &RepairService::upload_mesh},
      {"LoadServerMesh", &RepairService::load_server_mesh},
      {"ExportMesh", &RepairService::export_mesh},
      {"ListHoles", &RepairService::list_holes},
      {"FindNearestHole", &RepairService::find_nearest_hole},
      {"FillHoles", &RepairService::fill_holes},
      {"Stitch", &RepairService::stitch},
      {"Sharpen", &RepairService::sharpen},
      {"ListGaps", &RepairService::list_gaps},
      {"BridgeGaps", &RepairService::bridge_gaps},
      {"SharpEdge", &RepairService::sharp_edge},
      {"Undo", &RepairService::undo},
      {"Redo", &RepairService::redo},
      {"Subscribe", &RepairService::subscribe},
      {"Interact", &RepairService::interact},
      {"SubmitFillJob", &RepairService::submit_fill_job},
      {"GetJob", &RepairService::get_job},
      {"WatchJob", &RepairService::watch_job},
      {"CancelJob", &RepairService::cancel_job},
      {"FetchJobResult", &RepairService::fetch_job_result},
      {"ListJobs", &RepairService::list_jobs},
  };
}

Status RepairService::recover() {
  std::size_t count = 0;
  for (SessionRow& row : store_.load_sessions()) {
    auto session =
        std::make_shared<Session>(std::move(row), store_, pool_, metrics_, options_.session);
    if (Status s = session->recover(); !s.is_ok()) {
      log_event(spdlog::level::err, "session_recovery_failed",
                {{"session_id", session->id()}, {"msg", s.message}});
      return s;
    }
    std::lock_guard lock(mutex_);
    sessions_[session->id()] = session;
    ++count;
  }
  log_event(spdlog::level::info, "sessions_recovered", {{"sessions", count}});
  return {};
}

void RepairService::snapshot_all() {
  std::vector<SessionPtr> all;
  {
    std::lock_guard lock(mutex_);
    for (auto& [id, s] : sessions_) all.push_back(s);
  }
  std::vector<std::future<void>> done;
  for (auto& s : all) {
    auto promise = std::make_shared<std::promise<void>>();
    done.push_back(promise->get_future());
    asio::post(s->strand(), [s, promise] {
      s->snapshot();
      s->close_subscribers();
      promise->set_value();
    });
  }
  for (auto& f : done) f.wait();
}

std::size_t RepairService::session_count() const {
  std::lock_guard lock(mutex_);
  return sessions_.size();
}

void RepairService::start_call(const CallPtr& call) {
  auto it = handlers_.find(call->method().name);
  if (it == handlers_.end()) {
    call->finish(
        {StatusCode::Unimplemented, "method " + call->method().name + " is not implemented"});
    return;
  }
  (this->*(it->second))(call);
}

Status RepairService::open_session(const std::string& principal, const std::string& id,
                                   SessionPtr& out, bool owner_only) {
  if (id.empty()) return {StatusCode::InvalidArgument, "session_id is required"};
  std::lock_guard lock(mutex_);
  auto it = sessions_.find(id);
  if (it == sessions_.end()) return {StatusCode::NotFound, "no session " + id};
  if (owner_only ? it->second->row().owner != principal : !it->second->allows(principal)) {
    metrics_.auth_failures.fetch_add(1);
    return {StatusCode::PermissionDenied,
            std::string(owner_only ? "only the owner may do this on session "
                                   : "no access to session ") +
                id};
  }
  out = it->second;
  return {};
}

// ---------------------------------------------------------------------------------------

void RepairService::health(const CallPtr& call) {
  unary<v1::HealthRequest>(call, [this, call](const v1::HealthRequest&) {
    v1::HealthResponse r;
    const StoreCondition store = store_.condition();
    r.set_serving(store.health == StoreHealth::Ok);
    r.set_not_serving_reason(store.reason);
    r.set_version(options_.version);
    r.set_sessions(static_cast<std::uint32_t>(session_count()));
    r.set_jobs_queued(static_cast<std::uint32_t>(jobs_.queued()));
    reply(call, {}, r);
  });
}

void RepairService::create_session(const CallPtr& call) {
  unary<v1::CreateSessionRequest>(call, [this, call](const v1::CreateSessionRequest& req) {
    if (req.name().size() > 256) {
      call->finish({StatusCode::InvalidArgument, "session name longer than 256 bytes"});
      return;
    }
    SessionPtr session;
    {
      std::lock_guard lock(mutex_);
      if (!req.request_id().empty()) {
        for (auto& [id, s] : sessions_) {
          if (s->row().owner == call->principal() && s->row().request_id == req.request_id()) {
            reply(call, {}, s->summary());
            return;
          }
        }
      }
      SessionRow row;
      row.id = random_id();
      row.name = req.name().empty() ? "session" : req.name();
      row.owner = call->principal();
      row.created_ms = unix_now_ms();
      row.request_id = req.request_id();
      if (Status s = store_.insert_session(row); !s.is_ok()) {
        call->finish(s);
        return;
      }
      session =
          std::make_shared<Session>(std::move(row), store_, pool_, metrics_, options_.session);
      sessions_[session->id()] = session;
    }
    log_event(spdlog::level::info, "session_created",
              {{"session_id", session->id()}, {"principal", call->principal()}});
    reply(call, {}, session->summary());
  });
}

void RepairService::list_sessions(const CallPtr& call) {
  unary<v1::ListSessionsRequest>(call, [this, call](const v1::ListSessionsRequest&) {
    v1::ListSessionsResponse r;
    std::lock_guard lock(mutex_);
    for (auto& [id, s] : sessions_) {
      if (s->allows(call->principal())) *r.add_sessions() = s->summary();
    }
    reply(call, {}, r);
  });
}

void RepairService::open_session_rpc(const CallPtr& call) {
  on_session<v1::SessionRef>(call, [call](const v1::SessionRef&, const SessionPtr& session) {
    reply(call, {}, session->info());
  });
}

void RepairService::share_session(const CallPtr& call) {
  unary<v1::ShareSessionRequest>(call, [this, call](const v1::ShareSessionRequest& req) {
    SessionPtr session;
    Status s = open_session(call->principal(), req.session_id(), session, true);
    if (s.is_ok() && (req.principal().empty() || req.principal().size() > 128)) {
      s = {StatusCode::InvalidArgument, "principal is required (at most 128 bytes)"};
    }
    if (s.is_ok()) s = store_.set_member(req.session_id(), req.principal(), !req.revoke());
    if (!s.is_ok()) {
      call->finish(s);
      return;
    }
    session->set_member(req.principal(), !req.revoke());
    asio::post(session->strand(), [call, session] { reply(call, {}, session->info()); });
  });
}

void RepairService::close_session(const CallPtr& call) {
  unary<v1::SessionRef>(call, [this, call](const v1::SessionRef& req) {
    SessionPtr session;
    Status s = open_session(call->principal(), req.session_id(), session, true);
    if (s.is_ok()) s = store_.delete_session(req.session_id());
    if (!s.is_ok()) {
      call->finish(s);
      return;
    }
    {
      std::lock_guard lock(mutex_);
      sessions_.erase(req.session_id());
    }
    asio::post(session->strand(), [call, session] {
      session->close_subscribers();
      reply(call, {}, v1::CloseSessionResponse());
    });
    log_event(spdlog::level::info, "session_closed", {{"session_id", req.session_id()}});
  });
}

void RepairService::load_into(const CallPtr& call, const SessionPtr& session,
                              std::shared_ptr<std::string> bytes, v1::MeshFormat format,
                              const std::string& name) {
  asio::post(session->strand(), [this, call, session, bytes, format, name] {
    if (call->cancelled()) return;
    geometry::MeshFormat gformat;
    if (!to_geometry_format(format, gformat)) {
      call->finish({StatusCode::InvalidArgument, "unknown mesh format (OFF, OBJ, PLY or STL)"});
      return;
    }
    LoadedMesh loaded;
    if (Status s = load_document(*bytes, gformat, options_.session.limits, loaded); !s.is_ok()) {
      call->finish({s.code, name + ": " + s.message});
      return;
    }
    bytes->clear();
    v1::LoadMeshResponse response;
    Status s = session->load(std::move(loaded), name, call->principal(), response);
    reply(call, s, response);
  });
}

void RepairService::upload_mesh(const CallPtr& call) {
  auto session = std::make_shared<SessionPtr>();
  chunked_upload<v1::MeshChunk>(
      call, options_.session.limits.max_upload_bytes,
      [this, call, session](const v1::MeshChunk& first, std::uint64_t& declared) -> Status {
        if (!first.has_header()) {
          return {StatusCode::InvalidArgument, "the first upload chunk must carry the header"};
        }
        const auto& h = first.header();
        if (Status s = open_session(call->principal(), h.session_id(), *session); !s.is_ok())
          return s;
        geometry::MeshFormat f;
        if (!to_geometry_format(h.format(), f)) {
          return {StatusCode::InvalidArgument, "unknown mesh format (OFF, OBJ, PLY or STL)"};
        }
        declared = h.total_bytes();
        return {};
      },
      [this, call, session](const v1::MeshChunk& first, std::shared_ptr<std::string> bytes) {
        const auto& h = first.header();
        load_into(call, *session, std::move(bytes), h.format(),
                  h.name().empty() ? "upload" : h.name());
      });
}

void RepairService::load_server_mesh(const CallPtr& call) {
  unary<v1::LoadServerMeshRequest>(call, [this, call](const v1::LoadServerMeshRequest& req) {
    SessionPtr session;
    if (Status s = open_session(call->principal(), req.session_id(), session); !s.is_ok()) {
      call->finish(s);
      return;
    }
    // The path must stay inside the data dir (no absolute paths, no ".." escapes, no symlinks out).
    std::error_code ec;
    const auto root = std::filesystem::weakly_canonical(options_.data_dir, ec);
    const auto path = std::filesystem::weakly_canonical(options_.data_dir / req.path(), ec);
    const auto rel = path.lexically_relative(root);
    if (req.path().empty() || std::filesystem::path(req.path()).is_absolute() || ec ||
        rel.empty() || *rel.begin() == "..") {
      call->finish(
          {StatusCode::InvalidArgument, "path must be a file inside the server's data dir"});
      return;
    }
    geometry::MeshFormat gformat;
    if (!geometry::format_from_path(path.string(), gformat)) {
      call->finish(
          {StatusCode::InvalidArgument, "unknown extension (expected .stl .obj .off .ply)"});
      return;
    }
    const auto size = std::filesystem::file_size(path, ec);
    if (ec) {
      call->finish({StatusCode::NotFound, "no file " + req.path() + " in the data dir"});
      return;
    }
    if (size > options_.session.limits.max_upload_bytes) {
      call->finish({StatusCode::ResourceExhausted, req.path() + " exceeds the mesh size limit"});
      return;
    }
    std::ifstream in(path, std::ios::binary);
    auto bytes = std::make_shared<std::string>(size, '\0');
    if (!in.read(bytes->data(), static_cast<std::streamsize>(size))) {
      call->finish({StatusCode::Unavailable, "cannot read " + req.path()});
      return;
    }
    static const v1::MeshFormat formats[] = {v1::OFF, v1::OBJ, v1::PLY, v1::STL};
    load_into(call, session, bytes, formats[static_cast<int>(gformat)], req.path());
  });
}

void RepairService::export_mesh(const CallPtr& call) {
  on_session<v1::ExportMeshRequest>(
      call, [call](const v1::ExportMeshRequest& req, const SessionPtr& session) {
        auto bytes = std::make_shared<std::string>();
        if (Status s = session->export_mesh(req, *bytes); !s.is_ok()) {
          call->finish(s);
          return;
        }
        stream_chunks(call, bytes);
      });
}

void RepairService::list_holes(const CallPtr& call) {
  on_session<v1::SessionRef>(call, [call](const v1::SessionRef&, const SessionPtr& session) {
    v1::ListHolesResponse r;
    r.set_version(session->version());
    for (auto& h : session->holes()) *r.add_holes() = std::move(h);
    reply(call, {}, r);
  });
}

void RepairService::find_nearest_hole(const CallPtr& call) {
  on_session<v1::FindNearestHoleRequest>(
      call, [call](const v1::FindNearestHoleRequest& req, const SessionPtr& session) {
        if (!finite(req.point())) {
          call->finish({StatusCode::InvalidArgument, "the point is not finite"});
          return;
        }
        const auto nearest = session->nearest_hole(req.point());
        if (!nearest.found) {
          call->finish({StatusCode::NotFound, "the mesh has no holes"});
          return;
        }
        v1::FindNearestHoleResponse r;
        r.set_version(session->version());
        *r.mutable_hole() = nearest.hole;
        r.set_distance(nearest.distance);
        reply(call, {}, r);
      });
}

void RepairService::fill_holes(const CallPtr& call) {
  on_session<v1::FillHolesRequest>(
      call, [call](const v1::FillHolesRequest& req, const SessionPtr& session) {
        v1::EditResponse response;
        Status s = session->fill(req, call->principal(), call.get(), response);
        reply(call, s, response);
      });
}

void RepairService::stitch(const CallPtr& call) {
  on_session<v1::StitchRequest>(call,
                                [call](const v1::StitchRequest& req, const SessionPtr& session) {
                                  v1::EditResponse response;
                                  Status s = session->stitch(req, call->principal(), response);
                                  reply(call, s, response);
                                });
}

void RepairService::sharpen(const CallPtr& call) {
  on_session<v1::SharpenRequest>(call,
                                 [call](const v1::SharpenRequest& req, const SessionPtr& session) {
                                   v1::EditResponse response;
                                   Status s = session->sharpen(req, call->principal(), response);
                                   reply(call, s, response);
                                 });
}

void RepairService::list_gaps(const CallPtr& call) {
  on_session<v1::ListGapsRequest>(
      call, [call](const v1::ListGapsRequest& req, const SessionPtr& session) {
        v1::ListGapsResponse response;
        Status s = session->list_gaps(req, response);
        reply(call, s, response);
      });
}

void RepairService::bridge_gaps(const CallPtr& call) {
  on_session<v1::BridgeGapsRequest>(
      call, [call](const v1::BridgeGapsRequest& req, const SessionPtr& session) {
        v1::EditResponse response;
        Status s = session->bridge_gaps(req, call->principal(), response);
        reply(call, s, response);
      });
}

void RepairService::sharp_edge(const CallPtr& call) {
  on_session<v1::SharpEdgeRequest>(
      call, [call](const v1::SharpEdgeRequest& req, const SessionPtr& session) {
        v1::SharpEdgeResponse response;
        Status s = session->sharp_edge(req, call->principal(), response);
        reply(call, s, response);
      });
}

void RepairService::undo(const CallPtr& call) {
  step_history(call, Session::History::Undo);
}

void RepairService::redo(const CallPtr& call) {
  step_history(call, Session::History::Redo);
}

void RepairService::step_history(const CallPtr& call, Session::History direction) {
  on_session<v1::HistoryRequest>(
      call, [call, direction](const v1::HistoryRequest& req, const SessionPtr& session) {
        v1::EditResponse response;
        Status s = session->step_history(direction, call->principal(), response, req.request_id());
        reply(call, s, response);
      });
}

void RepairService::subscribe(const CallPtr& call) {
  unary<v1::SubscribeRequest>(call, [this, call](const v1::SubscribeRequest& req) {
    SessionPtr session;
    if (Status s = open_session(call->principal(), req.session_id(), session); !s.is_ok()) {
      call->finish(s);
      return;
    }
    std::weak_ptr<Session> weak = session;
    call->on_cancel = [weak, call] {
      if (auto s = weak.lock()) {
        asio::post(s->strand(), [s, call] { s->unsubscribe(call->connection_id(), call->id()); });
      }
    };
    asio::post(session->strand(), [call, session, req] {
      if (call->cancelled()) return;
      if (Status s = session->subscribe(call, req.after_version()); !s.is_ok()) call->finish(s);
    });
  });
}

// The haptic station's bidirectional stream: tool samples (conflated: only the latest
// unprocessed pose matters), hole selections and Hermite points.
void RepairService::interact(const CallPtr& call) {
  struct State {
    SessionPtr session;
    std::uint64_t last_seq = 0;
    std::uint64_t received = 0;
    std::uint64_t conflated = 0;
    std::optional<v1::ToolSample> pending;  // latest pose not yet processed
    bool scheduled = false;
    std::chrono::steady_clock::time_point last_ack{};
    std::chrono::steady_clock::time_point last_presence{};
    std::mutex mutex;  // pending/scheduled are shared with the session strand
    v1::Presence presence;
  };
  auto state = std::make_shared<State>();
  auto send_ack = [call, state] {
    v1::InteractionEvent event;
    auto* ack = event.mutable_ack();
    ack->set_last_seq(state->last_seq);
    ack->set_client_id(static_cast<std::uint32_t>(call->connection_id()));
    ack->set_tool_samples_received(state->received);
    {
      std::lock_guard lock(state->mutex);
      ack->set_tool_samples_conflated(state->conflated);
    }
    state->last_ack = std::chrono::steady_clock::now();
    call->send(event.SerializeAsString());
  };
  call->on_message = [this, call, state, send_ack](std::string_view payload) {
    if (call->finished()) return;
    v1::InteractionMessage message;
    if (!message.ParseFromArray(payload.data(), static_cast<int>(payload.size()))) {
      call->finish({StatusCode::InvalidArgument, "not a valid InteractionMessage"});
      return;
    }
    if (!state->session) {
      if (Status s = open_session(call->principal(), message.session_id(), state->session);
          !s.is_ok()) {
        call->finish(s);
        return;
      }
      state->presence.set_principal(call->principal());
      state->presence.set_client_id(static_cast<std::uint32_t>(call->connection_id()));
    }
    SessionPtr session = state->session;
    // One tool sample: validated, counted, conflated to the newest pose for the session's
    // strand (presence at up to 30 Hz). False if the call was finished (bad sample).
    const auto accept_tool = [&](const v1::ToolSample& tool) -> bool {
      if (!finite(tool.position()) || !finite(tool.direction()) || !std::isfinite(tool.radius())) {
        call->finish({StatusCode::InvalidArgument, "tool sample with NaN/inf"});
        return false;
      }
      state->last_seq = std::max(state->last_seq, tool.seq());
      ++state->received;
      metrics_.tool_samples.fetch_add(1, std::memory_order_relaxed);
      bool schedule = false;
      {
        std::lock_guard lock(state->mutex);
        if (state->pending && !state->pending->stroke_begin() && !state->pending->stroke_end()) {
          ++state->conflated;  // superseded before the session got to it
          metrics_.tool_samples_conflated.fetch_add(1, std::memory_order_relaxed);
        }
        state->pending = tool;
        if (!state->scheduled) state->scheduled = schedule = true;
      }
      if (schedule) {
        asio::post(session->strand(), [session, state] {
          std::optional<v1::ToolSample> sample;
          {
            std::lock_guard lock(state->mutex);
            sample = std::move(state->pending);
            state->pending.reset();
            state->scheduled = false;
          }
          if (!sample) return;
          *state->presence.mutable_tool_position() = sample->position();
          // Other operators see the tool at up to 30 Hz; the haptic loop itself is local.
          const auto now = std::chrono::steady_clock::now();
          if (now - state->last_presence >= std::chrono::milliseconds(33) || sample->stroke_end()) {
            state->last_presence = now;
            session->publish_presence(state->presence);
          }
        });
      }
      if (tool.stroke_end() ||
          std::chrono::steady_clock::now() - state->last_ack >= std::chrono::milliseconds(50)) {
        send_ack();
      }
      return true;
    };
    switch (message.body_case()) {
      case v1::InteractionMessage::kTool:
        accept_tool(message.tool());
        return;
      case v1::InteractionMessage::kTools: {
        if (message.tools().samples_size() > 1000) {
          call->finish({StatusCode::InvalidArgument, "more than 1000 tool samples in a batch"});
          return;
        }
        for (const auto& tool : message.tools().samples())
          if (!accept_tool(tool)) return;
        return;
      }
      case v1::InteractionMessage::kSelection: {
        const auto sel = message.selection();
        if (!finite(sel.point())) {
          call->finish({StatusCode::InvalidArgument, "selection point with NaN/inf"});
          return;
        }
        state->last_seq = std::max(state->last_seq, sel.seq());
        asio::post(session->strand(), [call, session, state, sel] {
          const auto nearest = session->nearest_hole(sel.point());
          v1::InteractionEvent event;
          auto* r = event.mutable_selection();
          r->set_seq(sel.seq());
          r->set_found(nearest.found);
          if (nearest.found) {
            *r->mutable_hole() = nearest.hole;
            r->set_distance(nearest.distance);
            state->presence.set_selected_hole(nearest.hole.id());
            state->presence.set_has_selection(true);
            session->publish_presence(state->presence);
          }
          call->send(event.SerializeAsString());
        });
        return;
      }
      case v1::InteractionMessage::kHermite: {
        const auto& h = message.hermite();
        if (!finite(h.position()) || h.index() > 3) {
          call->finish(
              {StatusCode::InvalidArgument, "Hermite point needs a finite position and index 0-3"});
          return;
        }
        state->last_seq = std::max(state->last_seq, h.seq());
        send_ack();
        return;
      }
      default:
        call->finish({StatusCode::InvalidArgument, "empty InteractionMessage"});
        return;
    }
  };
  call->on_half_close = [call, state, send_ack] {
    if (call->finished()) return;
    send_ack();
    call->finish({});
  };
}

void RepairService::submit_fill_job(const CallPtr& call) {
  chunked_upload<v1::JobChunk>(
      call, options_.session.limits.max_upload_bytes,
      [](const v1::JobChunk& first, std::uint64_t& declared) -> Status {
        if (!first.has_spec()) {
          return {StatusCode::InvalidArgument, "the first job chunk must carry the spec"};
        }
        declared = first.spec().total_bytes();
        return {};
      },
      [this, call](const v1::JobChunk& first, std::shared_ptr<std::string> bytes) {
        v1::Job job;
        Status s = jobs_.submit(call->principal(), first.spec(), std::move(*bytes), job);
        reply(call, s, job);
      });
}

void RepairService::get_job(const CallPtr& call) {
  unary<v1::JobRef>(call, [this, call](const v1::JobRef& req) {
    v1::Job job;
    Status s = jobs_.get(call->principal(), req.job_id(), job);
    reply(call, s, job);
  });
}

void RepairService::watch_job(const CallPtr& call) {
  unary<v1::JobRef>(call, [this, call](const v1::JobRef& req) {
    if (Status s = jobs_.watch(call->principal(), req.job_id(), call); !s.is_ok()) call->finish(s);
  });
}

void RepairService::cancel_job(const CallPtr& call) {
  unary<v1::JobRef>(call, [this, call](const v1::JobRef& req) {
    v1::Job job;
    Status s = jobs_.cancel(call->principal(), req.job_id(), job);
    reply(call, s, job);
  });
}

void RepairService::fetch_job_result(const CallPtr& call) {
  unary<v1::JobRef>(call, [this, call](const v1::JobRef& req) {
    auto bytes = std::make_shared<std::string>();
    if (Status s = jobs_.result(call->principal(), req.job_id(), *bytes); !s.is_ok()) {
      call->finish(s);
      return;
    }
    stream_chunks(call, bytes);
  });
}

void RepairService::list_jobs(const CallPtr& call) {
  unary<v1::ListJobsRequest>(call, [this, call](const v1::ListJobsRequest&) {
    v1::ListJobsResponse r;
    for (auto& j : jobs_.list(call->principal())) *r.add_jobs() = std::move(j);
    reply(call, {}, r);
  });
}

}  // namespace touchmend::service
