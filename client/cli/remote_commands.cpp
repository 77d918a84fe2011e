// The `touchmend` subcommands that run against a touchmend-server (--server).

#include <cstdlib>
#include <fstream>
#include <iostream>
#include <random>
#include <sstream>
#include <thread>
#include <unistd.h>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "client/cli/commands.h"
#include "client/cli/reports.h"
#include "client/net/repair_client.h"
#include "server/geometry/mesh_io.h"
#include "server/geometry/sharpen.h"

namespace touchmend::cli {

bool wire_format(const std::string& path, v1::MeshFormat& format) {
  geometry::MeshFormat f;
  if (!geometry::format_from_path(path, f)) return false;
  static const v1::MeshFormat map[] = {v1::OFF, v1::OBJ, v1::PLY, v1::STL};
  format = map[static_cast<int>(f)];
  return true;
}

namespace {

using net::Status;
using net::StatusCode;

//! Maps a server status to the CLI's exit codes: the caller's input is wrong (1) or the
//! server is (4).
int exit_for(const Status& s) {
  switch (s.code) {
    case StatusCode::InvalidArgument:
    case StatusCode::NotFound:
    case StatusCode::FailedPrecondition:
    case StatusCode::OutOfRange:
      return kExitBadInput;
    default:
      return kExitServer;
  }
}

int report(const Status& s, std::ostream& err, const std::string& what) {
  err << "error: " << what << ": " << s.to_string() << "\n";
  return exit_for(s);
}

//! The CLI's retry policy for --retries: 0.2 s doubling up to 5 s (about 20 s for 6 retries).
net::RetryPolicy retry_policy(const RemoteArgs& remote) {
  net::RetryPolicy policy;
  policy.max_attempts = remote.retries + 1;
  policy.initial_backoff = std::chrono::milliseconds(200);
  policy.max_backoff = std::chrono::milliseconds(5'000);
  return policy;
}

//! A client connected to --server (tried again while it is unreachable, per --retries), with
//! the retry policy set; null with \p code and a message on failure.
std::unique_ptr<net::RepairClient> open_client(const RemoteArgs& remote, std::ostream& err,
                                               int& code) {
  net::ChannelOptions options;
  std::string error;
  if (!net::parse_server_address(remote.server, options, error)) {
    err << "error: --server: " << error << "\n";
    code = kExitUsage;
    return nullptr;
  }
  options.token = remote.token;
  if (options.token.empty()) {
    if (const char* env = std::getenv("TOUCHMEND_TOKEN")) options.token = env;
  }
  options.tls = remote.tls || !remote.tls_ca.empty();
  options.tls_ca = remote.tls_ca;
  const net::RetryPolicy policy = retry_policy(remote);
  auto backoff = policy.initial_backoff;
  Status status;
  for (int attempt = 1;; ++attempt) {
    if (auto channel = net::Channel::connect(options, status)) {
      auto client = std::make_unique<net::RepairClient>(std::move(channel));
      client->set_retry_policy(policy);
      return client;
    }
    if (status.code != StatusCode::Unavailable || attempt >= policy.max_attempts) break;
    err << fmt::format("touchmend: {}: {}; trying again in {:.1f} s ({} of {}, --retries)\n",
                       remote.server, status.message, backoff.count() / 1000.0, attempt,
                       policy.max_attempts - 1);
    std::this_thread::sleep_for(backoff);
    backoff = std::min(policy.max_backoff, backoff * 2);
  }
  err << "error: " << remote.server << ": " << status.to_string() << "\n";
  code = kExitServer;
  return nullptr;
}

//! A fresh idempotency key (AIP-155): 128 random bits in hex.
std::string new_request_id() {
  std::random_device random;
  std::string id;
  for (int i = 0; i < 4; ++i) id += fmt::format("{:08x}", random());
  return id;
}

bool read_file(const std::string& path, std::string& bytes, std::ostream& err) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    err << "error: " << path << ": cannot open the file\n";
    return false;
  }
  std::ostringstream buffer;
  buffer << in.rdbuf();
  bytes = buffer.str();
  return true;
}

bool make_selection(const FillArgs& args, v1::HoleSelection& selection, v1::FillOptions& options,
                    std::ostream& err) {
  const int modes = (args.all ? 1 : 0) + (args.hole_ids.empty() ? 0 : 1) + (args.near ? 1 : 0);
  if (modes != 1) {
    err << "error: choose exactly one of --all, --hole ID... or --near X,Y,Z\n";
    return false;
  }
  if (args.all) selection.set_all(true);
  for (auto id : args.hole_ids) selection.mutable_ids()->add_ids(id);
  if (args.near) {
    selection.mutable_near()->set_x((*args.near)[0]);
    selection.mutable_near()->set_y((*args.near)[1]);
    selection.mutable_near()->set_z((*args.near)[2]);
  }
  options.set_refine_iterations(static_cast<std::uint32_t>(args.refine_iterations));
  options.set_max_boundary(static_cast<std::uint32_t>(args.max_boundary));
  if (args.shape == "flat")
    options.set_shape(v1::PATCH_SHAPE_FLAT);
  else if (args.shape == "fair")
    options.set_shape(v1::PATCH_SHAPE_FAIR);
  else if (args.shape == "auto")
    options.set_shape(v1::PATCH_SHAPE_AUTO);
  else {
    err << "error: --shape must be flat, fair or auto\n";
    return false;
  }
  if (args.sharp == "auto")
    options.set_sharp(v1::SHARP_AUTO);
  else if (args.sharp == "off")
    options.set_sharp(v1::SHARP_OFF);
  else {
    err << "error: --sharp must be off or auto\n";
    return false;
  }
  options.set_crease_angle_deg(args.crease_angle);
  options.set_remove_fragments(args.remove_fragments);
  return true;
}

nlohmann::json hole_json(const v1::Hole& h) {
  return {{"id", h.id()},
          {"boundary_edges", h.boundary_edges()},
          {"perimeter", h.perimeter()},
          {"area", h.area()},
          {"simple", h.simple()},
          {"centroid", {h.centroid().x(), h.centroid().y(), h.centroid().z()}},
          {"normal", {h.normal().x(), h.normal().y(), h.normal().z()}},
          {"loop", std::vector<std::uint32_t>(h.loop().begin(), h.loop().end())},
          {"pinched_at", std::vector<std::uint32_t>(h.pinched_at().begin(), h.pinched_at().end())},
          {"fragment_faces", h.fragment_faces()},
          {"unfillable_reason", h.unfillable_reason()}};
}

nlohmann::json fill_json(const v1::HoleFillResult& r) {
  return {{"hole_id", r.hole_id()},
          {"boundary_vertices", r.boundary_vertices()},
          {"filled", r.filled()},
          {"skipped", r.skipped()},
          {"reason", r.reason()},
          {"method", r.method()},
          {"shape", r.shape()},
          {"shape_reason", r.shape_reason()},
          {"faces_added", r.faces_added()},
          {"vertices_added", r.vertices_added()},
          {"min_angle_deg", r.min_angle_deg()},
          {"fragment_faces_removed", r.fragment_faces_removed()},
          {"seconds", r.seconds()}};
}

std::string fill_line(const v1::HoleFillResult& r) {
  if (r.skipped()) return fmt::format("hole {:>6}: skipped ({})\n", r.hole_id(), r.reason());
  if (r.fragment_faces_removed() > 0)
    return fmt::format("hole {:>6}: removed: {}\n", r.hole_id(), r.reason());
  if (!r.filled()) return fmt::format("hole {:>6}: LEFT OPEN: {}\n", r.hole_id(), r.reason());
  return fmt::format(
      "hole {:>6}: filled, {} boundary edges, method {}, shape {} ({}), {} faces and {} vertices "
      "added, smallest angle {:.1f} deg, {:.2f} ms\n",
      r.hole_id(), r.boundary_vertices(), r.method(), r.shape(), r.shape_reason(), r.faces_added(),
      r.vertices_added(), r.min_angle_deg(), r.seconds() * 1e3);
}

//! Holes neither filled, skipped, nor closed by removing a fragment.
std::size_t left_open(const v1::FillReport& report) {
  std::size_t open = 0;
  for (const auto& h : report.holes())
    open += !h.filled() && !h.skipped() && h.fragment_faces_removed() == 0;
  return open;
}

void print_fill_report(const v1::FillReport& report, bool json, const nlohmann::json& extra,
                       std::ostream& out) {
  std::size_t filled = 0, open = 0, skipped = 0, removed = 0;
  for (const auto& h : report.holes()) {
    filled += h.filled();
    skipped += h.skipped();
    removed += h.fragment_faces_removed() > 0;
  }
  open = left_open(report);
  if (json) {
    nlohmann::json holes = nlohmann::json::array();
    for (const auto& h : report.holes()) holes.push_back(fill_json(h));
    nlohmann::json j = extra;
    j["holes_found"] = report.holes_found();
    j["selected"] = report.holes_size();
    j["filled"] = filled;
    j["left_open"] = open;
    j["skipped"] = skipped;
    j["fragments_removed"] = removed;
    j["holes"] = holes;
    out << j.dump(2) << "\n";
    return;
  }
  for (const auto& h : report.holes()) out << fill_line(h);
  out << fill_summary(filled, static_cast<std::size_t>(report.holes_size()), open, skipped, removed,
                      report.holes_found());
}

//! A temporary session holding the uploaded file; closed (deleted) on scope exit.
struct TemporarySession {
  net::RepairClient& client;
  std::string id;
  ~TemporarySession() {
    if (id.empty()) return;
    // Clean-up, not the command's work: one more try (after a reconnect) at most, so a command
    // that already failed on an unreachable server does not wait the whole --retries again.
    net::RetryPolicy once;
    once.max_attempts = 2;
    client.set_retry_policy(once);
    client.close_session(id);
  }
};

int upload_into_session(net::RepairClient& client, const std::string& file,
                        TemporarySession& session, std::ostream& err) {
  v1::MeshFormat format;
  if (!wire_format(file, format)) {
    err << "error: " << file
        << ": unknown mesh file extension (expected .stl, .obj, .off or .ply)\n";
    return kExitBadInput;
  }
  std::string bytes;
  if (!read_file(file, bytes, err)) return kExitBadInput;
  v1::SessionInfo info;
  if (Status s = client.create_session("touchmend " + file, info, new_request_id()); !s.is_ok()) {
    return report(s, err, "create session");
  }
  session.id = info.session_id();
  v1::LoadMeshResponse loaded;
  const auto slash = file.find_last_of('/');
  if (Status s =
          client.upload_mesh(session.id, bytes, format,
                             slash == std::string::npos ? file : file.substr(slash + 1), loaded,
                             /*repeatable=*/true);  // the session is this command's own
      !s.is_ok()) {
    return report(s, err, file);
  }
  return kExitOk;
}

bool write_output(const std::string& path, const std::string& bytes, std::ostream& err) {
  std::string error;
  if (!geometry::write_file_atomically(path, bytes, error)) {
    err << "error: " << error << "\n";
    return false;
  }
  return true;
}

}  // namespace

int run_holes_remote(const HolesArgs& args, const RemoteArgs& remote, std::ostream& out,
                     std::ostream& err) {
  int code = kExitOk;
  const auto connected = open_client(remote, err, code);
  if (!connected) return code;
  net::RepairClient& client = *connected;
  TemporarySession session{client, {}};
  if (int c = upload_into_session(client, args.file, session, err); c != kExitOk) return c;
  v1::ListHolesResponse holes;
  if (Status s = client.list_holes(session.id, holes); !s.is_ok())
    return report(s, err, "list holes");
  if (args.json) {
    nlohmann::json list = nlohmann::json::array();
    for (const auto& h : holes.holes()) list.push_back(hole_json(h));
    out << nlohmann::json{{"file", args.file}, {"server", remote.server}, {"holes", list}}.dump(2)
        << "\n";
    return kExitOk;
  }
  if (holes.holes().empty()) {
    out << "no holes: the mesh is closed\n";
    return kExitOk;
  }
  out << fmt::format("{:>8} {:>6} {:>12} {:>12} {:>8}  {}\n", "id", "edges", "perimeter", "area",
                     "kind", "centroid");
  for (const auto& h : holes.holes()) {
    out << fmt::format(
        "{:>8} {:>6} {:>12.6g} {:>12.6g} {:>8}  ({:.6g}, {:.6g}, {:.6g}){}\n", h.id(),
        h.boundary_edges(), h.perimeter(), h.area(), h.simple() ? "simple" : "complex",
        h.centroid().x(), h.centroid().y(), h.centroid().z(),
        pinch_note(std::vector<std::uint32_t>(h.pinched_at().begin(), h.pinched_at().end())) +
            fragment_note(h.fragment_faces()) +
            (h.unfillable_reason().empty() ? "" : "  unfillable: " + h.unfillable_reason()));
  }
  return kExitOk;
}

int run_fill_remote(const FillArgs& args, const RemoteArgs& remote, std::ostream& out,
                    std::ostream& err) {
  v1::MeshFormat out_format;
  if (!wire_format(args.output, out_format)) {
    err << "error: " << args.output
        << ": unknown output extension (expected .stl, .obj, .off or .ply)\n";
    return kExitUsage;
  }
  v1::FillHolesRequest request;
  if (!make_selection(args, *request.mutable_selection(), *request.mutable_options(), err))
    return kExitUsage;
  int code = kExitOk;
  const auto connected = open_client(remote, err, code);
  if (!connected) return code;
  net::RepairClient& client = *connected;
  TemporarySession session{client, {}};
  if (int c = upload_into_session(client, args.file, session, err); c != kExitOk) return c;
  request.set_session_id(session.id);
  request.set_request_id(new_request_id());
  v1::EditResponse edit;
  if (Status s = client.fill_holes(request, edit); !s.is_ok()) return report(s, err, args.file);
  std::string bytes;
  if (Status s = client.export_mesh(session.id, out_format, args.binary, bytes); !s.is_ok()) {
    return report(s, err, "export");
  }
  if (!write_output(args.output, bytes, err)) return kExitBadInput;
  print_fill_report(edit.report(), args.json,
                    {{"input", args.file},
                     {"output", args.output},
                     {"server", remote.server},
                     {"version", edit.version()}},
                    out);
  if (!args.json) out << fmt::format("wrote {}\n", args.output);
  return args.strict && left_open(edit.report()) > 0 ? kExitLeftOpen : kExitOk;
}

namespace {

nlohmann::json job_json(const v1::Job& job) {
  nlohmann::json j = {{"job_id", job.job_id()},
                      {"state", v1::JobState_Name(job.state())},
                      {"progress", job.progress()},
                      {"stage", job.stage()},
                      {"name", job.name()},
                      {"attempts", job.attempts()},
                      {"created_unix_ms", job.created_unix_ms()},
                      {"finished_unix_ms", job.finished_unix_ms()},
                      {"result_bytes", job.result_bytes()}};
  if (job.has_error() && job.error().code() != 0) {
    j["error"] = {{"code", rpc::to_string(rpc::status_code_from_int(job.error().code()))},
                  {"message", job.error().message()}};
  }
  return j;
}

void print_job(const v1::Job& job, bool json, std::ostream& out) {
  if (json) {
    out << job_json(job).dump(2) << "\n";
    return;
  }
  out << fmt::format(
      "job {}  {}  {:.0f}%  {}{}\n", job.job_id(), v1::JobState_Name(job.state()),
      job.progress() * 100, job.name(),
      job.has_error() && job.error().code() != 0 ? "  error: " + job.error().message() : "");
}

int job_exit(const v1::Job& job) {
  switch (job.state()) {
    case v1::SUCCEEDED:
      return kExitOk;
    case v1::FAILED: {
      const auto code = rpc::status_code_from_int(job.error().code());
      return code == StatusCode::InvalidArgument || code == StatusCode::NotFound ? kExitBadInput
                                                                                 : kExitServer;
    }
    default:
      return kExitServer;
  }
}

int wait_for_job(net::RepairClient& client, const std::string& id, const std::string& output,
                 bool json, const RemoteArgs& remote, std::ostream& out, std::ostream& err) {
  v1::Job job;
  bool have = false;
  const bool show_progress = !json && &err == &std::cerr && ::isatty(STDERR_FILENO) != 0;
  // A job outlives a server restart (it runs again), so a watch cut by one is started again,
  // per --retries.
  const net::RetryPolicy policy = retry_policy(remote);
  auto backoff = policy.initial_backoff;
  std::unique_ptr<net::Stream> stream;
  for (int attempt = 1;; ++attempt) {
    stream = client.watch_job(id);
    while (stream->read(job, std::chrono::hours(24))) {
      have = true;
      attempt = 1;  // the server is back: the retries start over
      backoff = policy.initial_backoff;
      if (show_progress)
        err << fmt::format("job {}: {} {:.0f}%\r", id, v1::JobState_Name(job.state()),
                           job.progress() * 100)
            << std::flush;
    }
    if (stream->status().code != StatusCode::Unavailable || attempt >= policy.max_attempts) break;
    std::this_thread::sleep_for(backoff);
    backoff = std::min(policy.max_backoff, backoff * 2);
    if (!client.channel()->is_open()) (void)client.reconnect();
  }
  if (show_progress) err << "\n";
  if (Status s = stream->status(); !s.is_ok()) return report(s, err, "job " + id);
  if (!have) return report({StatusCode::Internal, "no job state received"}, err, "job " + id);
  if (job.state() == v1::SUCCEEDED && !output.empty()) {
    std::string bytes;
    if (Status s = client.fetch_job_result(id, bytes); !s.is_ok()) return report(s, err, "fetch");
    if (!write_output(output, bytes, err)) return kExitBadInput;
  }
  if (job.state() == v1::SUCCEEDED) {
    print_fill_report(job.report(), json, {{"job_id", id}, {"output", output}}, out);
    if (!json && !output.empty()) out << fmt::format("wrote {}\n", output);
  } else {
    print_job(job, json, out);
  }
  return job_exit(job);
}

}  // namespace

int run_job(const JobArgs& args, const RemoteArgs& remote, std::ostream& out, std::ostream& err) {
  if (remote.server.empty()) {
    err << "error: jobs run on a server: add --server HOST:PORT\n";
    return kExitUsage;
  }
  if (args.action != "submit" && args.action != "list" && args.job_id.empty()) {
    err << "error: job " << args.action << " needs a job id\n";
    return kExitUsage;
  }
  if (args.action == "fetch" && args.fill.output.empty()) {
    err << "error: job fetch needs -o OUT\n";
    return kExitUsage;
  }
  v1::JobSpec spec;
  std::string bytes;
  if (args.action == "submit") {
    v1::MeshFormat format;
    if (!wire_format(args.fill.file, format)) {
      err << "error: " << args.fill.file
          << ": unknown mesh file extension (expected .stl, .obj, .off or .ply)\n";
      return kExitBadInput;
    }
    if (!args.fill.output.empty() && !args.wait) {
      err << "error: -o needs --wait (or fetch the result later with `job fetch ID -o OUT`)\n";
      return kExitUsage;
    }
    if (!make_selection(args.fill, *spec.mutable_selection(), *spec.mutable_options(), err))
      return kExitUsage;
    spec.set_format(format);
    spec.set_binary_output(args.fill.binary);
    spec.set_request_id(new_request_id());
    const auto slash = args.fill.file.find_last_of('/');
    spec.set_name(slash == std::string::npos ? args.fill.file : args.fill.file.substr(slash + 1));
    if (!read_file(args.fill.file, bytes, err)) return kExitBadInput;
  }
  int code = kExitOk;
  const auto connected = open_client(remote, err, code);
  if (!connected) return code;
  net::RepairClient& client = *connected;
  v1::Job job;
  if (args.action == "submit") {
    if (Status s = client.submit_job(spec, bytes, job); !s.is_ok()) return report(s, err, "submit");
    if (!args.wait) {
      if (args.fill.json) {
        out << job_json(job).dump(2) << "\n";
      } else {
        out << job.job_id() << "\n";
      }
      return kExitOk;
    }
    return wait_for_job(client, job.job_id(), args.fill.output, args.fill.json, remote, out, err);
  }
  if (args.action == "status") {
    if (Status s = client.get_job(args.job_id, job); !s.is_ok())
      return report(s, err, "job " + args.job_id);
    print_job(job, args.fill.json, out);
    return kExitOk;
  }
  if (args.action == "wait")
    return wait_for_job(client, args.job_id, args.fill.output, args.fill.json, remote, out, err);
  if (args.action == "cancel") {
    if (Status s = client.cancel_job(args.job_id, job); !s.is_ok())
      return report(s, err, "job " + args.job_id);
    print_job(job, args.fill.json, out);
    return kExitOk;
  }
  if (args.action == "fetch") {
    std::string result;
    if (Status s = client.fetch_job_result(args.job_id, result); !s.is_ok())
      return report(s, err, "job " + args.job_id);
    if (!write_output(args.fill.output, result, err)) return kExitBadInput;
    out << fmt::format("wrote {} ({} bytes)\n", args.fill.output, result.size());
    return kExitOk;
  }
  if (args.action == "list") {
    v1::ListJobsResponse list;
    if (Status s = client.list_jobs(list); !s.is_ok()) return report(s, err, "list jobs");
    if (args.fill.json) {
      nlohmann::json j = nlohmann::json::array();
      for (const auto& jb : list.jobs()) j.push_back(job_json(jb));
      out << j.dump(2) << "\n";
    } else {
      for (const auto& jb : list.jobs()) print_job(jb, false, out);
    }
    return kExitOk;
  }
  err << "error: unknown job action " << args.action
      << " (submit, status, wait, cancel, fetch, list)\n";
  return kExitUsage;
}

namespace {

//! Uploads FILE into a temporary session, runs \p edit, exports into OUTPUT.
template <typename Edit>
int edit_remotely(const RemoteArgs& remote, const std::string& file, const std::string& output,
                  bool binary, std::ostream& err, v1::EditResponse& response, Edit edit) {
  v1::MeshFormat out_format;
  if (!wire_format(output, out_format)) {
    err << "error: " << output
        << ": unknown output extension (expected .stl, .obj, .off or .ply)\n";
    return kExitUsage;
  }
  int code = kExitOk;
  const auto connected = open_client(remote, err, code);
  if (!connected) return code;
  net::RepairClient& client = *connected;
  TemporarySession session{client, {}};
  if (int c = upload_into_session(client, file, session, err); c != kExitOk) return c;
  if (Status s = edit(client, session.id, response); !s.is_ok()) return report(s, err, file);
  std::string bytes;
  if (Status s = client.export_mesh(session.id, out_format, binary, bytes); !s.is_ok())
    return report(s, err, "export");
  if (!write_output(output, bytes, err)) return kExitBadInput;
  return kExitOk;
}

//! The edit's one-line summary (and where it was written), or \p fields with it as JSON.
void print_summary(const v1::EditResponse& response, bool json, nlohmann::json fields,
                   const std::string& output, std::ostream& out) {
  if (json) {
    fields["summary"] = response.summary();
    fields["version"] = response.version();
    out << fields.dump(2) << "\n";
  } else {
    out << response.summary() << "\nwrote " << output << "\n";
  }
}

v1::Point3 wire_point(const geometry::Vec3& p) {
  v1::Point3 q;
  q.set_x(p[0]);
  q.set_y(p[1]);
  q.set_z(p[2]);
  return q;
}

}  // namespace

int run_sharpen_remote(const SharpenArgs& args, const RemoteArgs& remote, std::ostream& out,
                       std::ostream& err) {
  geometry::PickedCreases picked;
  if (!parse_sharpen_picks(args, picked, err)) return kExitUsage;
  if (args.depth != 0 && args.method != "push-down") {
    err << "error: --depth applies to --method push-down\n";
    return kExitUsage;
  }
  if (!args.finish.empty() && args.method != "push-down") {
    err << "error: --finish applies to --method push-down\n";
    return kExitUsage;
  }
  // The same parsers as the local command, then the wire's enums.
  geometry::PushFinish finish = geometry::PushFinish::Fair;
  if (!args.finish.empty() && !geometry::parse_push_finish(args.finish, finish)) {
    err << "error: --finish must be fair, smooth or none\n";
    return kExitUsage;
  }
  geometry::PickTangents tangents = geometry::PickTangents::Crease;
  if (!geometry::parse_pick_tangents(args.tangents, tangents)) {
    err << "error: --tangents must be crease or chord\n";
    return kExitUsage;
  }
  v1::SharpenRequest request;
  request.set_request_id(new_request_id());
  request.set_finish(finish == geometry::PushFinish::Smooth ? v1::PUSH_FINISH_SMOOTH
                     : finish == geometry::PushFinish::None ? v1::PUSH_FINISH_NONE
                                                            : v1::PUSH_FINISH_FAIR);
  request.set_tangents(tangents == geometry::PickTangents::Chord ? v1::PICK_TANGENTS_CHORD
                                                                 : v1::PICK_TANGENTS_CREASE);
  request.set_hole_id(args.hole);
  for (const geometry::HermitePoints& curve : picked.curves)
    for (const auto& p : {curve.p1, curve.p2, curve.p3, curve.p4})
      *request.add_points() = wire_point(p);
  for (const geometry::CreasePick& crease : picked.corner) {
    *request.add_corner() = wire_point(crease.far);
    *request.add_corner() = wire_point(crease.rim);
  }
  request.set_k1(args.k1);
  request.set_k4(args.k4);
  request.set_method(args.method == "push-down" ? v1::SHARPEN_PUSH_DOWN : v1::SHARPEN_SPLIT);
  request.set_depth(args.depth);
  FillArgs fill;
  fill.all = true;
  fill.shape = args.shape;
  fill.refine_iterations = args.refine_iterations;
  v1::HoleSelection unused;
  if (!make_selection(fill, unused, *request.mutable_fill(), err)) return kExitUsage;
  v1::EditResponse response;
  const int code = edit_remotely(
      remote, args.file, args.output, args.binary, err, response,
      [&](net::RepairClient& client, const std::string& session, v1::EditResponse& r) {
        request.set_session_id(session);
        return client.sharpen(request, r);
      });
  if (code != kExitOk) return code;
  print_summary(response, args.json,
                {{"input", args.file},
                 {"output", args.output},
                 {"server", remote.server},
                 {"hole", args.hole},
                 {"method", args.method}},
                args.output, out);
  return kExitOk;
}

int run_gaps_remote(const GapsArgs& args, const RemoteArgs& remote, std::ostream& out,
                    std::ostream& err) {
  int code = kExitOk;
  const auto connected = open_client(remote, err, code);
  if (!connected) return code;
  net::RepairClient& client = *connected;
  TemporarySession session{client, {}};
  if (int c = upload_into_session(client, args.file, session, err); c != kExitOk) return c;
  v1::ListGapsRequest request;
  request.set_session_id(session.id);
  request.set_max_width(args.max_width);
  v1::ListGapsResponse response;
  if (Status s = client.list_gaps(request, response); !s.is_ok()) return report(s, err, args.file);
  if (args.json) {
    nlohmann::json list = nlohmann::json::array();
    for (const auto& g : response.gaps())
      list.push_back({{"id", g.id()},
                      {"hole_a", g.hole_a()},
                      {"hole_b", g.hole_b()},
                      {"cyclic", g.cyclic()},
                      {"mean_width", g.mean_width()},
                      {"max_width", g.max_width()},
                      {"length", g.length()},
                      {"run_a", g.run_a()},
                      {"run_b", g.run_b()}});
    out << nlohmann::json{{"file", args.file}, {"server", remote.server}, {"gaps", list}}.dump(2)
        << "\n";
    return kExitOk;
  }
  if (response.gaps().empty())
    out << "no gaps: no two boundary runs face each other within the width\n";
  for (const auto& g : response.gaps())
    out << fmt::format(
        "gap {:>4}: loops {} and {}, {} and {} vertices, mean width {:.6g}, max "
        "{:.6g}, length {:.6g}{}\n",
        g.id(), g.hole_a(), g.hole_b(), g.run_a_size(), g.run_b_size(), g.mean_width(),
        g.max_width(), g.length(), g.cyclic() ? " (all around)" : "");
  return kExitOk;
}

int run_bridge_remote(const BridgeArgs& args, const RemoteArgs& remote, std::ostream& out,
                      std::ostream& err) {
  if (args.all == !args.gap_ids.empty()) {
    err << "error: choose exactly one of --all or --gap ID...\n";
    return kExitUsage;
  }
  v1::BridgeGapsRequest request;
  request.set_request_id(new_request_id());
  if (args.all) request.set_all(true);
  for (const auto id : args.gap_ids) request.mutable_ids()->add_ids(id);
  request.set_max_width(args.max_width);
  v1::EditResponse response;
  const int code = edit_remotely(
      remote, args.file, args.output, args.binary, err, response,
      [&](net::RepairClient& client, const std::string& session, v1::EditResponse& r) {
        request.set_session_id(session);
        return client.bridge_gaps(request, r);
      });
  if (code != kExitOk) return code;
  print_summary(response, args.json,
                {{"input", args.file}, {"output", args.output}, {"server", remote.server}},
                args.output, out);
  return kExitOk;
}

}  // namespace touchmend::cli
