#include "client/net/repair_client.h"

#include <future>
#include <random>
#include <thread>

namespace touchmend::net {

using namespace std::chrono_literals;

namespace {
v1::SessionRef ref(const std::string& id) {
  v1::SessionRef r;
  r.set_session_id(id);
  return r;
}
v1::JobRef job_ref(const std::string& id) {
  v1::JobRef r;
  r.set_job_id(id);
  return r;
}
}  // namespace

std::shared_ptr<Channel> RepairClient::channel() const {
  std::lock_guard lock(mutex_);
  return channel_;
}

void RepairClient::set_retry_policy(const RetryPolicy& policy) {
  std::lock_guard lock(mutex_);
  retry_ = policy;
}

std::uint64_t RepairClient::retries() const {
  std::lock_guard lock(mutex_);
  return retries_;
}

template <class Attempt>
Status RepairClient::retrying(bool repeatable, Attempt&& attempt) {
  RetryPolicy policy;
  {
    std::lock_guard lock(mutex_);
    policy = retry_;
  }
  static thread_local std::mt19937 jitter(std::random_device{}());
  std::chrono::milliseconds backoff = policy.initial_backoff;
  for (int attempts = 1;; ++attempts) {
    Status s = attempt();
    if (s.code != StatusCode::Unavailable || !repeatable || attempts >= policy.max_attempts)
      return s;
    // Half to all of the backoff ("equal jitter"), so clients cut off together do not all come
    // back at once.
    std::uniform_int_distribution<long> wait(backoff.count() / 2, backoff.count());
    std::this_thread::sleep_for(std::chrono::milliseconds(wait(jitter)));
    backoff = std::min(policy.max_backoff, backoff * 2);
    {
      std::lock_guard lock(mutex_);
      ++retries_;
    }
    // A server that answered UNAVAILABLE itself keeps the connection; a lost one is replaced
    // (if that fails too, the attempt fails on the closed channel and the loop waits again).
    if (!channel()->is_open()) (void)reconnect();
  }
}

Status RepairClient::unary(const char* method, const google::protobuf::MessageLite& request,
                           google::protobuf::MessageLite& out, bool repeatable,
                           std::chrono::milliseconds timeout) {
  return retrying(repeatable,
                  [&] { return channel()->unary(method, request, out, timeout); });
}

Status RepairClient::reconnect() {
  const ChannelOptions options = channel()->options();
  Status status;
  auto fresh = Channel::connect(options, status);
  if (!fresh) return status;
  std::lock_guard lock(mutex_);
  channel_ = std::move(fresh);
  return {};
}

Status RepairClient::health(v1::HealthResponse& out) {
  return unary("Health", v1::HealthRequest(), out, true);
}

Status RepairClient::create_session(const std::string& name, v1::SessionInfo& out,
                                    const std::string& request_id) {
  v1::CreateSessionRequest req;
  req.set_name(name);
  req.set_request_id(request_id);
  return unary("CreateSession", req, out, !request_id.empty());
}

Status RepairClient::list_sessions(v1::ListSessionsResponse& out) {
  return unary("ListSessions", v1::ListSessionsRequest(), out, true);
}

Status RepairClient::open_session(const std::string& session_id, v1::SessionInfo& out) {
  return unary("OpenSession", ref(session_id), out, true);
}

Status RepairClient::share_session(const std::string& session_id, const std::string& principal,
                                   bool revoke, v1::SessionInfo& out) {
  v1::ShareSessionRequest req;
  req.set_session_id(session_id);
  req.set_principal(principal);
  req.set_revoke(revoke);
  return unary("ShareSession", req, out, true);  // sets a membership
}

Status RepairClient::close_session(const std::string& session_id) {
  v1::CloseSessionResponse out;
  return unary("CloseSession", ref(session_id), out, true);
}

template <class Chunk>
Status RepairClient::upload(const std::string& method, std::vector<Chunk> chunks,
                            google::protobuf::MessageLite& out) {
  struct Result {
    std::promise<Status> status;
    std::string payload;
  };
  auto result = std::make_shared<Result>();
  auto future = result->status.get_future();
  auto call = channel()->start_call(
      method, std::nullopt, false, std::chrono::milliseconds(0),
      [result](std::string payload) { result->payload = std::move(payload); },
      [result](Status s) { result->status.set_value(std::move(s)); });
  for (std::size_t i = 0; i < chunks.size(); ++i)
    call->send(chunks[i].SerializeAsString(), i + 1 == chunks.size());
  Status s = future.get();
  if (!s.is_ok()) return s;
  if (!out.ParseFromString(result->payload))
    return {StatusCode::Internal, "the server's response does not parse"};
  return {};
}

Status RepairClient::upload_mesh(const std::string& session_id, const std::string& bytes,
                                 v1::MeshFormat format, const std::string& name,
                                 v1::LoadMeshResponse& out, bool repeatable) {
  std::vector<v1::MeshChunk> chunks;
  for (std::size_t offset = 0; offset < bytes.size() || offset == 0; offset += rpc::kChunkBytes) {
    v1::MeshChunk chunk;
    if (offset == 0) {
      auto* h = chunk.mutable_header();
      h->set_session_id(session_id);
      h->set_format(format);
      h->set_total_bytes(bytes.size());
      h->set_name(name);
    }
    chunk.set_data(bytes.substr(offset, rpc::kChunkBytes));
    chunks.push_back(std::move(chunk));
    if (bytes.empty()) break;
  }
  return retrying(repeatable, [&] { return upload("UploadMesh", chunks, out); });
}

Status RepairClient::load_server_mesh(const std::string& session_id, const std::string& path,
                                      v1::LoadMeshResponse& out) {
  v1::LoadServerMeshRequest req;
  req.set_session_id(session_id);
  req.set_path(path);
  return unary("LoadServerMesh", req, out, false);  // a new version each time
}

Status RepairClient::download(const std::string& method,
                              const google::protobuf::MessageLite& request, std::string& bytes) {
  return retrying(true, [&] { return download_once(method, request, bytes); });
}

Status RepairClient::download_once(const std::string& method,
                                   const google::protobuf::MessageLite& request,
                                   std::string& bytes) {
  auto result = std::make_shared<std::promise<Status>>();
  auto data = std::make_shared<std::string>();
  auto future = result->get_future();
  channel()->start_call(
      method, request.SerializeAsString(), true, std::chrono::milliseconds(0),
      [data](std::string payload) {
        v1::MeshChunk chunk;
        if (chunk.ParseFromString(payload)) data->append(chunk.data());
      },
      [result](Status s) { result->set_value(std::move(s)); });
  Status s = future.get();
  if (s.is_ok()) bytes = std::move(*data);
  return s;
}

Status RepairClient::export_mesh(const std::string& session_id, v1::MeshFormat format, bool binary,
                                 std::string& bytes) {
  v1::ExportMeshRequest req;
  req.set_session_id(session_id);
  req.set_format(format);
  req.set_binary(binary);
  return download("ExportMesh", req, bytes);
}

Status RepairClient::download_document(const std::string& session_id, rpc::MeshDocument& document) {
  std::string bytes;
  if (Status s = export_mesh(session_id, v1::DOCUMENT, false, bytes); !s.is_ok()) return s;
  v1::MeshDocument proto;
  if (!proto.ParseFromString(bytes))
    return {StatusCode::Internal, "the session document does not parse"};
  return rpc::from_proto(proto, document);
}

Status RepairClient::list_holes(const std::string& session_id, v1::ListHolesResponse& out) {
  return unary("ListHoles", ref(session_id), out, true);
}

Status RepairClient::find_nearest_hole(const std::string& session_id, const v1::Point3& point,
                                       v1::FindNearestHoleResponse& out) {
  v1::FindNearestHoleRequest req;
  req.set_session_id(session_id);
  *req.mutable_point() = point;
  return unary("FindNearestHole", req, out, true);
}

Status RepairClient::fill_holes(const v1::FillHolesRequest& request, v1::EditResponse& out,
                                std::chrono::milliseconds timeout) {
  return unary("FillHoles", request, out, !request.request_id().empty(), timeout);
}

Status RepairClient::stitch(const v1::StitchRequest& request, v1::EditResponse& out) {
  return unary("Stitch", request, out, !request.request_id().empty());
}

Status RepairClient::sharpen(const v1::SharpenRequest& request, v1::EditResponse& out) {
  return unary("Sharpen", request, out, !request.request_id().empty());
}

Status RepairClient::list_gaps(const v1::ListGapsRequest& request, v1::ListGapsResponse& out) {
  return unary("ListGaps", request, out, true);
}

Status RepairClient::bridge_gaps(const v1::BridgeGapsRequest& request, v1::EditResponse& out) {
  return unary("BridgeGaps", request, out, !request.request_id().empty());
}

Status RepairClient::sharp_edge(const v1::SharpEdgeRequest& request, v1::SharpEdgeResponse& out) {
  return unary("SharpEdge", request, out, !request.request_id().empty());
}

namespace {
v1::HistoryRequest history_request(const std::string& session_id, const std::string& request_id) {
  v1::HistoryRequest r;
  r.set_session_id(session_id);
  r.set_request_id(request_id);
  return r;
}
}  // namespace

Status RepairClient::undo(const std::string& session_id, v1::EditResponse& out,
                          const std::string& request_id) {
  return unary("Undo", history_request(session_id, request_id), out, !request_id.empty());
}

Status RepairClient::redo(const std::string& session_id, v1::EditResponse& out,
                          const std::string& request_id) {
  return unary("Redo", history_request(session_id, request_id), out, !request_id.empty());
}

std::unique_ptr<Stream> RepairClient::server_stream(const std::string& method,
                                                    const google::protobuf::MessageLite& request) {
  auto stream = std::make_unique<Stream>();
  auto queue = stream->queue_;
  stream->call_ = channel()->start_call(
      method, request.SerializeAsString(), true, std::chrono::milliseconds(0),
      [queue](std::string payload) { queue->push(std::move(payload)); },
      [queue](Status s) { queue->finish(std::move(s)); });
  return stream;
}

std::unique_ptr<Stream> RepairClient::subscribe(const std::string& session_id,
                                                std::uint64_t after_version) {
  v1::SubscribeRequest req;
  req.set_session_id(session_id);
  req.set_after_version(after_version);
  return server_stream("Subscribe", req);
}

std::unique_ptr<Stream> RepairClient::interact() {
  auto stream = std::make_unique<Stream>();
  auto queue = stream->queue_;
  stream->call_ = channel()->start_call(
      "Interact", std::nullopt, false, std::chrono::milliseconds(0),
      [queue](std::string payload) { queue->push(std::move(payload)); },
      [queue](Status s) { queue->finish(std::move(s)); });
  return stream;
}

Status RepairClient::submit_job(v1::JobSpec spec, const std::string& bytes, v1::Job& out) {
  spec.set_total_bytes(bytes.size());
  std::vector<v1::JobChunk> chunks;
  for (std::size_t offset = 0; offset < bytes.size() || offset == 0; offset += rpc::kChunkBytes) {
    v1::JobChunk chunk;
    if (offset == 0) *chunk.mutable_spec() = spec;
    chunk.set_data(bytes.substr(offset, rpc::kChunkBytes));
    chunks.push_back(std::move(chunk));
    if (bytes.empty()) break;
  }
  return retrying(!spec.request_id().empty(),
                  [&] { return upload("SubmitFillJob", chunks, out); });
}

Status RepairClient::get_job(const std::string& job_id, v1::Job& out) {
  return unary("GetJob", job_ref(job_id), out, true);
}

std::unique_ptr<Stream> RepairClient::watch_job(const std::string& job_id) {
  return server_stream("WatchJob", job_ref(job_id));
}

Status RepairClient::cancel_job(const std::string& job_id, v1::Job& out) {
  return unary("CancelJob", job_ref(job_id), out, true);
}

Status RepairClient::fetch_job_result(const std::string& job_id, std::string& bytes) {
  return download("FetchJobResult", job_ref(job_id), bytes);
}

Status RepairClient::list_jobs(v1::ListJobsResponse& out) {
  return unary("ListJobs", v1::ListJobsRequest(), out, true);
}

// ---------------------------------------------------------------------------------------

SessionReplica::SessionReplica(RepairClient& client, std::string session_id)
    : client_(client), session_id_(std::move(session_id)) {}

Status SessionReplica::start() {
  return resync();
}

Status SessionReplica::resync() {
  if (stream_) stream_->cancel();
  // Subscribe first, then download: deltas that land in between arrive on the stream and
  // the ones the document already contains are skipped by version.
  stream_ = client_.subscribe(session_id_, 0);
  rpc::MeshDocument doc;
  if (Status s = client_.download_document(session_id_, doc); !s.is_ok()) return s;
  document_ = std::move(doc);
  ++resyncs_;
  return {};
}

Status SessionReplica::recover(std::chrono::steady_clock::time_point deadline) {
  static thread_local std::mt19937 jitter(std::random_device{}());
  while (std::chrono::steady_clock::now() < deadline) {
    if (client_.reconnect().is_ok()) {
      ++reconnects_;
      backoff_ = std::chrono::milliseconds(200);
      // Resume: the server replays the journal after our version, or sends a resync notice.
      stream_ = client_.subscribe(session_id_, document_.version);
      return {};
    }
    std::uniform_real_distribution<double> spread(0.8, 1.2);
    auto wait =
        std::chrono::milliseconds(static_cast<long>(double(backoff_.count()) * spread(jitter)));
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
        deadline - std::chrono::steady_clock::now());
    std::this_thread::sleep_for(std::min(wait, std::max(left, std::chrono::milliseconds(0))));
    backoff_ =
        std::min(std::chrono::milliseconds(10'000),
                 std::chrono::milliseconds(static_cast<long>(double(backoff_.count()) * 1.6)));
  }
  return {StatusCode::Unavailable, "the server is unreachable"};
}

Status SessionReplica::poll(std::chrono::milliseconds timeout) {
  if (!stream_) return {StatusCode::FailedPrecondition, "start() first"};
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  v1::SessionEvent event;
  auto wait = timeout;
  while (stream_->read(event, wait)) {
    wait = 0ms;
    switch (event.event_case()) {
      case v1::SessionEvent::kDelta: {
        const auto& d = event.delta();
        if (d.version() <= document_.version) break;  // already in the downloaded document
        if (d.base_version() != document_.version) {
          if (Status s = resync(); !s.is_ok()) return s;  // a gap: start over
          return {};
        }
        if (Status s = rpc::apply_delta(document_, d); !s.is_ok()) return s;
        ++deltas_applied_;
        if (on_delta) on_delta(d);
        break;
      }
      case v1::SessionEvent::kResync:
        if (event.resync().version() > document_.version) {
          if (Status s = resync(); !s.is_ok()) return s;
          return {};
        }
        break;
      case v1::SessionEvent::kPresence:
        if (on_presence) on_presence(event.presence());
        break;
      case v1::SessionEvent::kToolPreview:
        if (on_tool_preview) on_tool_preview(event.tool_preview());
        break;
      case v1::SessionEvent::kClosed:
        return {StatusCode::NotFound, "the session was closed"};
      default:
        break;
    }
  }
  if (stream_->finished()) {
    Status s = stream_->status();
    if (s.is_ok()) return {StatusCode::NotFound, "the session was closed"};
    if (s.code == StatusCode::Unavailable) return recover(deadline);  // connection lost
    return s;
  }
  return {};
}

Status SessionReplica::wait_for_version(std::uint64_t version, std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (document_.version < version) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
        deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) {
      return {StatusCode::DeadlineExceeded, "the replica is at version " +
                                                std::to_string(document_.version) + ", not " +
                                                std::to_string(version)};
    }
    if (Status s = poll(std::min(left, std::chrono::milliseconds(100))); !s.is_ok()) return s;
  }
  return {};
}

}  // namespace touchmend::net
