#pragma once

//! \file repair_client.h
//! \brief Typed calls for every RPC of touchmend.v1.Repair, on a Channel. Blocking calls are
//! safe from any thread except the channel's own network thread (never call them from a
//! stream callback).

#include <chrono>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "client/net/channel.h"
#include "proto/rpc/mesh_document.h"
#include "touchmend/v1/repair.pb.h"

namespace touchmend::net {

//! A live server stream (Subscribe, WatchJob, Interact): messages queue up for the reader.
class Stream {
 public:
  //! Next message, parsed; false at the end of the stream or on timeout.
  template <class Message>
  bool read(Message& message, std::chrono::milliseconds timeout) {
    std::string payload;
    if (!queue_->pop(payload, timeout)) return false;
    return message.ParseFromString(payload);
  }
  bool finished() const { return queue_->finished(); }
  Status status() const { return queue_->status(); }
  //! Sends a message on a bidirectional stream.
  void send(const google::protobuf::MessageLite& message) {
    call_->send(message.SerializeAsString());
  }
  void half_close() { call_->half_close(); }
  void cancel() { call_->cancel(); }

 private:
  friend class RepairClient;
  std::shared_ptr<ClientCall> call_;
  std::shared_ptr<StreamQueue> queue_ = std::make_shared<StreamQueue>();
};

//! When a call is sent again after UNAVAILABLE (the connection was lost, the server is
//! restarting, or its store failed and it waits for a restart). As AIP-194 advises, only
//! UNAVAILABLE is retried, and only calls that are safe to repeat: reads, and edits, session
//! creations and job submissions that carry a request_id (the server answers a repeated id with
//! what it already did, AIP-155). Mesh uploads and streams are never repeated (a
//! SessionReplica resumes its own stream). Off by default: one attempt.
struct RetryPolicy {
  int max_attempts = 1;
  std::chrono::milliseconds initial_backoff{100};  //!< doubled after each attempt, jittered
  std::chrono::milliseconds max_backoff{2'000};
};

class RepairClient {
 public:
  explicit RepairClient(std::shared_ptr<Channel> channel) : channel_(std::move(channel)) {}
  //! See RetryPolicy; a lost connection is replaced (reconnect()) before a retry.
  void set_retry_policy(const RetryPolicy& policy);
  //! Retries taken so far (for tests and diagnostics).
  std::uint64_t retries() const;
  //! The current channel (replaced by reconnect()).
  std::shared_ptr<Channel> channel() const;
  //! Opens a new connection with the same options (after the server went away). Calls in
  //! flight on the old one have already failed with UNAVAILABLE.
  Status reconnect();

  Status health(v1::HealthResponse& out);
  Status create_session(const std::string& name, v1::SessionInfo& out,
                        const std::string& request_id = "");
  Status list_sessions(v1::ListSessionsResponse& out);
  Status open_session(const std::string& session_id, v1::SessionInfo& out);
  Status share_session(const std::string& session_id, const std::string& principal, bool revoke,
                       v1::SessionInfo& out);
  Status close_session(const std::string& session_id);

  //! Uploads a mesh file's bytes into a session in 64 KiB chunks. A load is a new version each
  //! time, so it is retried (RetryPolicy) only when \p repeatable: the caller knows loading the
  //! same bytes again does no harm (a session of its own that it has not edited yet).
  Status upload_mesh(const std::string& session_id, const std::string& bytes, v1::MeshFormat format,
                     const std::string& name, v1::LoadMeshResponse& out, bool repeatable = false);
  Status load_server_mesh(const std::string& session_id, const std::string& path,
                          v1::LoadMeshResponse& out);
  Status export_mesh(const std::string& session_id, v1::MeshFormat format, bool binary,
                     std::string& bytes);
  //! The session's mesh document (slot arrays with their version) for a replica.
  Status download_document(const std::string& session_id, rpc::MeshDocument& document);

  Status list_holes(const std::string& session_id, v1::ListHolesResponse& out);
  Status find_nearest_hole(const std::string& session_id, const v1::Point3& point,
                           v1::FindNearestHoleResponse& out);
  Status fill_holes(const v1::FillHolesRequest& request, v1::EditResponse& out,
                    std::chrono::milliseconds timeout = std::chrono::minutes(10));
  Status stitch(const v1::StitchRequest& request, v1::EditResponse& out);
  Status sharpen(const v1::SharpenRequest& request, v1::EditResponse& out);
  Status list_gaps(const v1::ListGapsRequest& request, v1::ListGapsResponse& out);
  Status bridge_gaps(const v1::BridgeGapsRequest& request, v1::EditResponse& out);
  Status sharp_edge(const v1::SharpEdgeRequest& request, v1::SharpEdgeResponse& out);
  //! \p request_id (optional, AIP-155): sent again after a lost answer or a server restart, the
  //! same id gets the step already taken instead of another one.
  Status undo(const std::string& session_id, v1::EditResponse& out,
              const std::string& request_id = "");
  Status redo(const std::string& session_id, v1::EditResponse& out,
              const std::string& request_id = "");

  std::unique_ptr<Stream> subscribe(const std::string& session_id, std::uint64_t after_version);
  std::unique_ptr<Stream> interact();

  //! Submits a fill job; the mesh bytes travel in chunks after the spec.
  Status submit_job(v1::JobSpec spec, const std::string& bytes, v1::Job& out);
  Status get_job(const std::string& job_id, v1::Job& out);
  std::unique_ptr<Stream> watch_job(const std::string& job_id);
  Status cancel_job(const std::string& job_id, v1::Job& out);
  Status fetch_job_result(const std::string& job_id, std::string& bytes);
  Status list_jobs(v1::ListJobsResponse& out);

 private:
  Status download(const std::string& method, const google::protobuf::MessageLite& request,
                  std::string& bytes);
  Status download_once(const std::string& method, const google::protobuf::MessageLite& request,
                       std::string& bytes);
  std::unique_ptr<Stream> server_stream(const std::string& method,
                                        const google::protobuf::MessageLite& request);
  template <class Chunk>
  Status upload(const std::string& method, std::vector<Chunk> chunks,
                google::protobuf::MessageLite& out);
  //! \p attempt() under the retry policy; \p repeatable: whether the call may be sent again.
  template <class Attempt>
  Status retrying(bool repeatable, Attempt&& attempt);
  //! A unary call under the retry policy.
  Status unary(const char* method, const google::protobuf::MessageLite& request,
               google::protobuf::MessageLite& out, bool repeatable,
               std::chrono::milliseconds timeout = std::chrono::milliseconds(60'000));

  mutable std::mutex mutex_;
  std::shared_ptr<Channel> channel_;
  RetryPolicy retry_;
  std::uint64_t retries_ = 0;
};

//! A client-side copy of a session's mesh, kept current from the delta stream: download the
//! document, subscribe after its version, apply deltas in order, and download again on a
//! resync notice or a gap. Call poll() from the application's thread.
class SessionReplica {
 public:
  SessionReplica(RepairClient& client, std::string session_id);
  //! Downloads the document and subscribes.
  Status start();
  //! Applies the events that have arrived; waits up to \p timeout for the first one.
  Status poll(std::chrono::milliseconds timeout);
  //! When the connection drops, poll() reconnects with backoff (200 ms, x1.6, at most 10 s
  //! between attempts, ±20% jitter: SERVICE.md's interactive schedule) and resubscribes from
  //! the replica's version, so the journal replays what it missed. How many times it did:
  std::size_t reconnects() const { return reconnects_; }
  //! Polls until the replica reaches \p version (or the timeout passes).
  Status wait_for_version(std::uint64_t version, std::chrono::milliseconds timeout);
  const rpc::MeshDocument& document() const { return document_; }
  std::size_t deltas_applied() const { return deltas_applied_; }
  std::size_t resyncs() const { return resyncs_; }
  //! Called after each delta is applied (e.g. to update a view).
  std::function<void(const v1::MeshDelta&)> on_delta;
  std::function<void(const v1::Presence&)> on_presence;
  //! The session's sharp-edge tool preview (any client's, this one's included).
  std::function<void(const v1::ToolPreview&)> on_tool_preview;

 private:
  Status resync();
  //! Reconnects and resubscribes after \p version; false when \p deadline passes first.
  Status recover(std::chrono::steady_clock::time_point deadline);
  RepairClient& client_;
  std::string session_id_;
  rpc::MeshDocument document_;
  std::unique_ptr<Stream> stream_;
  std::size_t deltas_applied_ = 0;
  std::size_t resyncs_ = 0;
  std::size_t reconnects_ = 0;
  std::chrono::milliseconds backoff_{200};
};

}  // namespace touchmend::net
