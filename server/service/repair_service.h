#pragma once

//! \file repair_service.h
//! \brief The touchmend.v1.Repair service: every RPC of repair.proto, on top of the
//! sessions, the job manager and the store. Validates every request (sizes, ids, finite
//! coordinates, permissions) and answers each with a status.

#include <boost/asio.hpp>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "server/service/jobs.h"
#include "server/service/metrics.h"
#include "server/service/rpc_server.h"
#include "server/service/session.h"
#include "server/service/store.h"

namespace touchmend::service {

struct ServiceOptions {
  std::filesystem::path data_dir = "touchmend-data";
  SessionOptions session;
  std::string version = "0.1.0";
};

class RepairService final : public CallDispatcher {
 public:
  RepairService(Store& store, JobManager& jobs, asio::thread_pool& pool, Metrics& metrics,
                ServiceOptions options);

  //! Loads every stored session (snapshot + journal replay).
  Status recover();
  //! Snapshots every session (clean shutdown); blocks until done.
  void snapshot_all();
  std::size_t session_count() const;

  void start_call(const CallPtr& call) override;

 private:
  using Handler = void (RepairService::*)(const CallPtr&);
  Status open_session(const std::string& principal, const std::string& id, SessionPtr& out,
                      bool owner_only = false);

  void health(const CallPtr& call);
  void create_session(const CallPtr& call);
  void list_sessions(const CallPtr& call);
  void open_session_rpc(const CallPtr& call);
  void share_session(const CallPtr& call);
  void close_session(const CallPtr& call);
  void upload_mesh(const CallPtr& call);
  void load_server_mesh(const CallPtr& call);
  void export_mesh(const CallPtr& call);
  void list_holes(const CallPtr& call);
  void find_nearest_hole(const CallPtr& call);
  void fill_holes(const CallPtr& call);
  void stitch(const CallPtr& call);
  void sharpen(const CallPtr& call);
  void list_gaps(const CallPtr& call);
  void bridge_gaps(const CallPtr& call);
  void sharp_edge(const CallPtr& call);
  void undo(const CallPtr& call);
  void redo(const CallPtr& call);
  void step_history(const CallPtr& call, Session::History direction);
  void subscribe(const CallPtr& call);
  void interact(const CallPtr& call);
  void submit_fill_job(const CallPtr& call);
  void get_job(const CallPtr& call);
  void watch_job(const CallPtr& call);
  void cancel_job(const CallPtr& call);
  void fetch_job_result(const CallPtr& call);
  void list_jobs(const CallPtr& call);

  //! A unary call on one session: checks access, then runs \p work(request, session) on the
  //! session's strand (unless the call was cancelled meanwhile).
  template <class Request, class Work>
  void on_session(const CallPtr& call, Work work);
  void load_into(const CallPtr& call, const SessionPtr& session, std::shared_ptr<std::string> bytes,
                 v1::MeshFormat format, const std::string& name);

  Store& store_;
  JobManager& jobs_;
  asio::thread_pool& pool_;
  Metrics& metrics_;
  ServiceOptions options_;
  std::map<std::string, Handler> handlers_;
  mutable std::mutex mutex_;
  std::map<std::string, SessionPtr> sessions_;
};

}  // namespace touchmend::service
