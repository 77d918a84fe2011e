#include "server/service/jobs.h"

#include <openssl/rand.h>

#include "server/geometry/hole_filling.h"
#include "server/geometry/mesh_build.h"
#include "server/geometry/mesh_io.h"
#include "server/service/log.h"

namespace touchmend::service {

std::int64_t unix_now_ms() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

namespace {
bool is_final(int state) {
  return state == v1::SUCCEEDED || state == v1::FAILED || state == v1::CANCELLED;
}
}  // namespace

std::string random_id() {
  unsigned char bytes[16];
  if (RAND_bytes(bytes, sizeof bytes) != 1) {
    // OpenSSL's generator failing is not recoverable in a meaningful way; fall back to the
    // clock so ids stay unique within this process.
    const auto t = std::chrono::steady_clock::now().time_since_epoch().count();
    for (std::size_t i = 0; i < sizeof bytes; ++i)
      bytes[i] = static_cast<unsigned char>(t >> (i % 8 * 8));
  }
  static const char* hex = "0123456789abcdef";
  std::string id;
  for (unsigned char b : bytes) {
    id += hex[b >> 4];
    id += hex[b & 15];
  }
  return id;
}

BatchFillResult batch_fill(const std::string& input, const v1::JobSpec& spec,
                           const MeshLimits& limits, const std::function<bool(double)>& progress) {
  BatchFillResult result;
  geometry::MeshFormat format;
  if (!to_geometry_format(spec.format(), format)) {
    result.status = {StatusCode::InvalidArgument, "unknown mesh format"};
    return result;
  }
  if (input.size() > limits.max_upload_bytes) {
    result.status = {StatusCode::ResourceExhausted, "input over the upload limit"};
    return result;
  }
  geometry::ReadOptions read_options;
  read_options.max_elements = std::max(limits.max_vertices, limits.max_faces);
  geometry::ReadResult read = geometry::parse_mesh(input, format, read_options);
  if (!read.ok) {
    result.status = {StatusCode::InvalidArgument, read.error};
    return result;
  }
  if (read.soup.triangles.empty()) {
    result.status = {StatusCode::InvalidArgument, "the mesh has no faces"};
    return result;
  }
  if (read.soup.points.size() > limits.max_vertices ||
      read.soup.triangles.size() > limits.max_faces) {
    result.status = {StatusCode::ResourceExhausted, "the mesh exceeds the vertex or face limit"};
    return result;
  }
  geometry::Mesh mesh = geometry::build_mesh(read.soup).mesh;
  geometry::FillSelection selection;
  selection.max_boundary = spec.options().max_boundary();
  switch (spec.selection().mode_case()) {
    case v1::HoleSelection::kIds:
      selection.mode = geometry::FillSelection::Mode::Ids;
      selection.ids.assign(spec.selection().ids().ids().begin(),
                           spec.selection().ids().ids().end());
      break;
    case v1::HoleSelection::kNear:
      selection.mode = geometry::FillSelection::Mode::Nearest;
      selection.point = geometry::Vec3(spec.selection().near().x(), spec.selection().near().y(),
                                       spec.selection().near().z());
      break;
    default:
      selection.mode = geometry::FillSelection::Mode::All;
      break;
  }
  if (spec.options().refine_iterations() > 5) {
    result.status = {StatusCode::InvalidArgument, "refine_iterations must be 1-5 (0 = default)"};
    return result;
  }
  bool stopped = false;
  const geometry::FillReport report = geometry::fill_holes(
      mesh, selection, to_fill_options(spec.options()), [&](std::size_t done, std::size_t total) {
        const bool go_on =
            !progress || progress(total ? 0.05 + 0.9 * double(done) / double(total) : 0.95);
        stopped = stopped || !go_on;
        return go_on;
      });
  if (stopped) {
    result.status = {StatusCode::Cancelled, "cancelled"};
    return result;
  }
  if (!report.unknown_ids.empty()) {
    std::string list;
    for (auto id : report.unknown_ids) list += (list.empty() ? "" : ", ") + std::to_string(id);
    result.status = {StatusCode::NotFound, "no hole with id " + list};
    return result;
  }
  result.report.set_holes_found(static_cast<std::uint32_t>(report.holes_found));
  for (const auto& h : report.holes) to_proto(h, *result.report.add_holes());
  geometry::WriteOptions write_options;  // the writer skips deleted elements, in order
  write_options.binary = spec.binary_output();
  const geometry::WriteResult written =
      geometry::serialize_mesh(mesh, format, write_options, result.output);
  if (!written.ok) {
    result.status = {StatusCode::Internal, written.error};
    return result;
  }
  return result;
}

JobManager::JobManager(Store& store, Metrics& metrics, const JobOptions& options)
    : store_(store), metrics_(metrics), options_(options) {}

JobManager::~JobManager() {
  stop();
}

Status JobManager::start() {
  for (JobRow& row : store_.load_jobs()) {
    auto entry = std::make_shared<Entry>();
    entry->spec.ParseFromString(row.spec);
    entry->row = std::move(row);
    JobRow& r = entry->row;
    if (r.state == v1::RUNNING) {
      // The server stopped while this job ran: run it again, unless it keeps failing.
      if (r.attempts >= options_.max_attempts) {
        r.state = v1::FAILED;
        r.error_code = static_cast<int>(StatusCode::Aborted);
        r.error_message =
            "the server stopped during each of " + std::to_string(r.attempts) + " attempts";
        r.finished_ms = unix_now_ms();
        store_.update_job(r);
      } else {
        r.state = v1::QUEUED;
        store_.update_job(r);
      }
    }
    if (r.state == v1::QUEUED) queue_.push_back(r.id);
    if (is_final(r.state)) entry->progress = 1;
    jobs_[r.id] = entry;
  }
  log_event(spdlog::level::info, "jobs_recovered",
            {{"jobs", jobs_.size()}, {"queued", queue_.size()}});
  for (std::size_t i = 0; i < std::max<std::size_t>(1, options_.workers); ++i) {
    workers_.emplace_back([this] { worker_loop(); });
  }
  return {};
}

void JobManager::stop() {
  {
    std::lock_guard lock(mutex_);
    if (stopping_ && workers_.empty()) return;
    stopping_ = true;
    for (auto& [id, e] : jobs_)
      e->cancel = true;  // running jobs stop; they stay RUNNING in the store
  }
  wake_.notify_all();
  for (auto& t : workers_) t.join();
  workers_.clear();
}

v1::Job JobManager::to_proto(const Entry& e) const {
  v1::Job job;
  job.set_job_id(e.row.id);
  job.set_state(static_cast<v1::JobState>(e.row.state));
  job.set_progress(e.progress);
  job.set_stage(e.stage.empty() ? v1::JobState_Name(static_cast<v1::JobState>(e.row.state))
                                : e.stage);
  if (!e.row.report.empty()) job.mutable_report()->ParseFromString(e.row.report);
  if (e.row.error_code != 0) {
    job.mutable_error()->set_code(e.row.error_code);
    job.mutable_error()->set_message(e.row.error_message);
  }
  job.set_created_unix_ms(e.row.created_ms);
  job.set_finished_unix_ms(e.row.finished_ms);
  job.set_attempts(e.row.attempts);
  job.set_name(e.spec.name());
  job.set_result_bytes(e.row.result_bytes);
  return job;
}

Status JobManager::submit(const std::string& principal, const v1::JobSpec& spec, std::string input,
                          v1::Job& job) {
  geometry::MeshFormat format;
  if (!to_geometry_format(spec.format(), format)) {
    return {StatusCode::InvalidArgument, "the job needs the input's format (OFF, OBJ, PLY or STL)"};
  }
  if (spec.options().refine_iterations() > 5) {
    return {StatusCode::InvalidArgument, "refine_iterations must be 1-5 (0 = default)"};
  }
  std::unique_lock lock(mutex_);
  if (!spec.request_id().empty()) {
    for (const auto& [id, e] : jobs_) {
      if (e->row.principal == principal && e->spec.request_id() == spec.request_id()) {
        job = to_proto(*e);
        return {};
      }
    }
  }
  if (stopping_) return {StatusCode::Unavailable, "the server is shutting down"};
  if (queue_.size() >= options_.max_queued) {
    metrics_.jobs_rejected_busy.fetch_add(1);
    return {StatusCode::ResourceExhausted,
            "busy: " + std::to_string(queue_.size()) + " jobs are queued (the limit); retry later"};
  }
  auto entry = std::make_shared<Entry>();
  entry->spec = spec;
  entry->row.id = random_id();
  entry->row.principal = principal;
  entry->row.state = v1::QUEUED;
  entry->row.spec = spec.SerializeAsString();
  entry->row.created_ms = unix_now_ms();
  if (Status s = store_.insert_job(entry->row, input); !s.is_ok()) return s;
  jobs_[entry->row.id] = entry;
  queue_.push_back(entry->row.id);
  metrics_.jobs_submitted.fetch_add(1);
  job = to_proto(*entry);
  lock.unlock();
  wake_.notify_one();
  log_event(spdlog::level::info, "job_submitted",
            {{"job_id", entry->row.id}, {"principal", principal}, {"bytes", input.size()}});
  return {};
}

Status JobManager::find(const std::string& principal, const std::string& id,
                        std::shared_ptr<Entry>& out) {
  auto it = jobs_.find(id);
  // Another principal's job is reported as absent: its existence is not theirs to know.
  if (it == jobs_.end() || it->second->row.principal != principal) {
    return {StatusCode::NotFound, "no job " + id};
  }
  out = it->second;
  return {};
}

Status JobManager::get(const std::string& principal, const std::string& id, v1::Job& job) {
  std::lock_guard lock(mutex_);
  std::shared_ptr<Entry> e;
  if (Status s = find(principal, id, e); !s.is_ok()) return s;
  job = to_proto(*e);
  return {};
}

Status JobManager::cancel(const std::string& principal, const std::string& id, v1::Job& job) {
  std::shared_ptr<Entry> e;
  {
    std::lock_guard lock(mutex_);
    if (Status s = find(principal, id, e); !s.is_ok()) return s;
    if (e->row.state == v1::QUEUED) {
      queue_.erase(std::remove(queue_.begin(), queue_.end(), id), queue_.end());
    } else if (e->row.state == v1::RUNNING) {
      e->cancel = true;  // the worker stops at the next hole and records CANCELLED
      job = to_proto(*e);
      return {};
    } else {
      job = to_proto(*e);  // already final: cancelling is a no-op (as in gRPC)
      return {};
    }
  }
  finish(e, v1::CANCELLED, {StatusCode::Cancelled, "cancelled by the client"}, nullptr, nullptr);
  std::lock_guard lock(mutex_);
  job = to_proto(*e);
  return {};
}

Status JobManager::result(const std::string& principal, const std::string& id, std::string& bytes) {
  {
    std::lock_guard lock(mutex_);
    std::shared_ptr<Entry> e;
    if (Status s = find(principal, id, e); !s.is_ok()) return s;
    if (e->row.state != v1::SUCCEEDED) {
      return {StatusCode::FailedPrecondition,
              "job " + id + " is " + v1::JobState_Name(static_cast<v1::JobState>(e->row.state)) +
                  ", not SUCCEEDED"};
    }
  }
  auto stored = store_.job_result(id);
  if (!stored) return {StatusCode::DataLoss, "the result of job " + id + " is missing"};
  bytes = std::move(*stored);
  return {};
}

std::vector<v1::Job> JobManager::list(const std::string& principal) {
  std::lock_guard lock(mutex_);
  std::vector<v1::Job> out;
  for (const auto& [id, e] : jobs_) {
    if (e->row.principal == principal) out.push_back(to_proto(*e));
  }
  return out;
}

Status JobManager::watch(const std::string& principal, const std::string& id, const CallPtr& call) {
  std::lock_guard lock(mutex_);
  std::shared_ptr<Entry> e;
  if (Status s = find(principal, id, e); !s.is_ok()) return s;
  const v1::Job job = to_proto(*e);
  if (is_final(e->row.state)) {
    call->finish({}, job.SerializeAsString());
    return {};
  }
  call->send(job.SerializeAsString());
  e->watchers.push_back(call);
  return {};
}

std::size_t JobManager::queued() const {
  std::lock_guard lock(mutex_);
  return queue_.size();
}

std::size_t JobManager::running() const {
  std::lock_guard lock(mutex_);
  return running_;
}

std::size_t JobManager::expire() {
  std::vector<std::string> expired;
  {
    std::lock_guard lock(mutex_);
    const std::int64_t cutoff =
        unix_now_ms() -
        std::chrono::duration_cast<std::chrono::milliseconds>(options_.result_ttl).count();
    for (auto it = jobs_.begin(); it != jobs_.end();) {
      if (is_final(it->second->row.state) && it->second->row.finished_ms < cutoff) {
        expired.push_back(it->first);
        it = jobs_.erase(it);
      } else {
        ++it;
      }
    }
  }
  for (const auto& id : expired) store_.delete_job(id);
  return expired.size();
}

void JobManager::notify(const std::shared_ptr<Entry>& e, bool final) {
  // Called with mutex_ held.
  const std::string bytes = to_proto(*e).SerializeAsString();
  for (auto& w : e->watchers) {
    if (final) {
      w->finish({}, bytes);
    } else {
      w->send_droppable(bytes);
    }
  }
  if (final) e->watchers.clear();
}

void JobManager::finish(const std::shared_ptr<Entry>& e, int state, Status error,
                        const v1::FillReport* report, const std::string* result) {
  JobRow row;
  {
    std::lock_guard lock(mutex_);
    row = e->row;
  }
  row.state = state;
  row.finished_ms = unix_now_ms();
  row.error_code = static_cast<int>(error.code);
  row.error_message = error.message;
  if (report) row.report = report->SerializeAsString();
  Status stored = result ? store_.set_job_result(row, *result) : store_.update_job(row);
  if (result) row.result_bytes = result->size();
  if (!stored.is_ok()) {
    row.state = v1::FAILED;
    row.error_code = static_cast<int>(stored.code);
    row.error_message = "could not store the result: " + stored.message;
    store_.update_job(row);
  }
  std::lock_guard lock(mutex_);
  e->row = row;
  e->progress = 1;
  e->stage.clear();
  notify(e, true);
}

void JobManager::worker_loop() {
  for (;;) {
    std::shared_ptr<Entry> e;
    {
      std::unique_lock lock(mutex_);
      wake_.wait(lock, [this] { return stopping_ || !queue_.empty(); });
      if (stopping_) return;
      const std::string id = queue_.front();
      queue_.pop_front();
      auto it = jobs_.find(id);
      if (it == jobs_.end()) continue;
      e = it->second;
      e->row.state = v1::RUNNING;
      e->row.attempts += 1;
      e->stage = "running";
      ++running_;
      store_.update_job(e->row);  // RUNNING is durable before work starts (restart re-runs it)
      notify(e, false);
    }
    run(e);
    std::lock_guard lock(mutex_);
    --running_;
  }
}

void JobManager::run(const std::shared_ptr<Entry>& e) {
  const auto start = std::chrono::steady_clock::now();
  auto input = store_.job_input(e->row.id);
  if (!input) {
    finish(e, v1::FAILED, {StatusCode::DataLoss, "the job's input is missing"}, nullptr, nullptr);
    return;
  }
  auto last_notify = std::chrono::steady_clock::now();
  BatchFillResult result = batch_fill(*input, e->spec, options_.limits, [&](double progress) {
    std::lock_guard lock(mutex_);
    e->progress = progress;
    e->stage = "filling";
    const auto now = std::chrono::steady_clock::now();
    if (now - last_notify > std::chrono::milliseconds(100)) {
      last_notify = now;
      notify(e, false);
    }
    return !e->cancel.load();
  });
  {
    std::lock_guard lock(mutex_);
    if (stopping_) return;  // shutting down: leave it RUNNING so the restart re-runs it
  }
  metrics_.job_duration.observe(
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  if (result.status.code == StatusCode::Cancelled) {
    finish(e, v1::CANCELLED, {StatusCode::Cancelled, "cancelled by the client"}, nullptr, nullptr);
  } else if (!result.status.is_ok()) {
    finish(e, v1::FAILED, result.status, nullptr, nullptr);
  } else {
    finish(e, v1::SUCCEEDED, {}, &result.report, &result.output);
  }
  log_event(spdlog::level::info, "job_finished",
            {{"job_id", e->row.id},
             {"state", v1::JobState_Name(static_cast<v1::JobState>(e->row.state))},
             {"duration_s",
              std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()}});
}

}  // namespace touchmend::service
