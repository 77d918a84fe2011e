#pragma once

//! \file jobs.h
//! \brief Fill jobs for automated clients, as long-running operations (SERVICE.md §1.2,
//! AIP-151): submit, watch or poll progress, cancel, fetch the result.
//!
//! \details Jobs run on their own worker pool so batch work never delays the interactive
//! sessions. The queue is bounded: a submission beyond it is refused with RESOURCE_EXHAUSTED
//! ("busy"). Every state change is written to the store before it is reported; after a
//! restart, queued jobs are queued again and a job that was running is re-run (up to
//! max_attempts, then failed with the reason). Finished jobs are kept for result_ttl.

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "server/service/metrics.h"
#include "server/service/rpc_server.h"
#include "server/service/session_geometry.h"
#include "server/service/store.h"
#include "touchmend/v1/repair.pb.h"

namespace touchmend::service {

struct JobOptions {
  std::size_t workers = 1;
  std::size_t max_queued = 64;
  std::uint32_t max_attempts = 3;
  std::chrono::seconds result_ttl{24 * 3600};
  MeshLimits limits;
};

class JobManager {
 public:
  JobManager(Store& store, Metrics& metrics, const JobOptions& options);
  ~JobManager();

  //! Loads the stored jobs and starts the workers.
  Status start();
  void stop();

  Status submit(const std::string& principal, const v1::JobSpec& spec, std::string input,
                v1::Job& job);
  Status get(const std::string& principal, const std::string& id, v1::Job& job);
  Status cancel(const std::string& principal, const std::string& id, v1::Job& job);
  Status result(const std::string& principal, const std::string& id, std::string& bytes);
  std::vector<v1::Job> list(const std::string& principal);
  //! Streams the job's state on \p call until it finishes.
  Status watch(const std::string& principal, const std::string& id, const CallPtr& call);

  std::size_t queued() const;
  std::size_t running() const;
  //! Deletes finished jobs older than the TTL; returns how many.
  std::size_t expire();

 private:
  struct Entry {
    JobRow row;
    v1::JobSpec spec;
    double progress = 0;
    std::string stage;
    std::atomic<bool> cancel{false};
    std::vector<CallPtr> watchers;
  };
  v1::Job to_proto(const Entry& e) const;
  Status find(const std::string& principal, const std::string& id, std::shared_ptr<Entry>& out);
  void worker_loop();
  void run(const std::shared_ptr<Entry>& entry);
  void notify(const std::shared_ptr<Entry>& entry, bool final);
  void finish(const std::shared_ptr<Entry>& entry, int state, Status error,
              const v1::FillReport* report, const std::string* result);

  Store& store_;
  Metrics& metrics_;
  JobOptions options_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::map<std::string, std::shared_ptr<Entry>> jobs_;
  std::deque<std::string> queue_;
  std::size_t running_ = 0;
  bool stopping_ = false;
  std::vector<std::thread> workers_;
};

//! Runs a fill job's work on bytes: parse, fill, serialize in the same format. Exposed so the
//! tests can compare a job's result with the in-process fill.
struct BatchFillResult {
  Status status;
  v1::FillReport report;
  std::string output;
};
BatchFillResult batch_fill(const std::string& input, const v1::JobSpec& spec,
                           const MeshLimits& limits,
                           const std::function<bool(double progress)>& progress);

//! A new random id (128 bits, hex) for sessions and jobs.
std::string random_id();
//! Milliseconds since the Unix epoch (timestamps stored with sessions and jobs).
std::int64_t unix_now_ms();

}  // namespace touchmend::service
