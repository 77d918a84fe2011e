// touchmend-service-bench: the service targets of DESIGN.md, measured against a real
// touchmend-server process on loopback.
//   1. round trip "select hole near a point -> fill -> delta received by another client" for a
//      300-boundary-vertex hole (target p99 <= 10 ms);
//   2. sweep streaming: N clients x 1,000 tool samples/s (target: 32 clients, no drops),
//      with the server's CPU and memory;
//   3. batch throughput: fill jobs per second over the shared cases with the default workers;
//   4. sharp-edge push-down: a tool sample (SharpEdge push, Algorithm VI) -> the move's delta at
//      a second client (target p99 <= 5 ms), on a 49k-face cube whose filled edge hole is pushed
//      back to the edge.
//   5. with --soak SECONDS only: the soak of SERVICE.md §5.3 (target: RSS growth < 5% after
//      warm-up, file descriptors stable), cycles of what the command line does per file.

#include <algorithm>
#include <array>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <sys/resource.h>
#include <thread>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "client/cli/commands.h"
#include "server/geometry/mesh_build.h"
#include "server/geometry/mesh_io.h"
#include "tests/integration/server_process.h"
#include "tests/support/cases.h"
#include "tests/support/mesh_factory.h"

using namespace touchmend;
using namespace touchmend::testing;
using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

namespace {

struct ProcessUsage {
  double cpu_seconds = 0;
  double rss_mib = 0;
  double peak_rss_mib = 0;
};

ProcessUsage usage_of(pid_t pid) {
  ProcessUsage u;
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string line;
  std::getline(stat, line);
  const auto close = line.rfind(')');
  std::istringstream fields(line.substr(close + 2));
  std::string f;
  unsigned long utime = 0, stime = 0;
  for (int i = 3; i <= 15 && fields >> f; ++i) {
    if (i == 14) utime = std::stoul(f);
    if (i == 15) stime = std::stoul(f);
  }
  u.cpu_seconds = double(utime + stime) / double(sysconf(_SC_CLK_TCK));
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  while (std::getline(status, line)) {
    if (line.rfind("VmRSS:", 0) == 0) u.rss_mib = std::stod(line.substr(6)) / 1024;
    if (line.rfind("VmHWM:", 0) == 0) u.peak_rss_mib = std::stod(line.substr(6)) / 1024;
  }
  return u;
}

std::string percentiles(std::vector<double> ms) {
  if (ms.empty()) return "no samples";
  std::sort(ms.begin(), ms.end());
  auto at = [&](double q) {
    return ms[std::min(ms.size() - 1, std::size_t(q * double(ms.size() - 1) + 0.5))];
  };
  return fmt::format("n={} min={:.3f} p50={:.3f} p90={:.3f} p99={:.3f} max={:.3f} ms", ms.size(),
                     ms.front(), at(0.5), at(0.9), at(0.99), ms.back());
}

std::string annulus_off(int inner) {
  return to_off(annulus(inner, 10.0, 6, 0.4));
}

// One measured interaction per iteration, then an undo so the hole is back for the next.
// `select_first`: the client asks FindNearestHole, then fills that id (two calls, as a client
// that shows the hole before filling it); otherwise one FillHoles call selects the hole nearest
// the point on the server (the haptic station's button press: it highlights holes from its own
// replica, so the press is the only round trip).
//! The mesh a round trip fills a hole of, and the point the hole is picked near.
struct RoundTripMesh {
  std::string bytes;
  v1::MeshFormat format = v1::OFF;
  std::string name;
  std::array<double, 3> near{};
  std::size_t faces = 0;
};

//! The default: a flat annulus of 3,600 faces round a 300-vertex hole, picked on its rim.
RoundTripMesh annulus_round_trip() {
  const geometry::MeshSoup soup = annulus(300, 10.0, 6, 0.4);
  return {to_off(soup), v1::OFF, "annulus300.off", {10.0, 0.0, 0.0}, soup.triangles.size()};
}

void round_trip(const ServerProcess& server, int iterations, bool select_first,
                const RoundTripMesh& mesh) {
  auto channel_a = server.connect();
  auto channel_b = server.connect();
  net::RepairClient a(channel_a), b(channel_b);
  v1::SessionInfo info;
  a.create_session("bench", info);
  v1::LoadMeshResponse loaded;
  if (auto s = a.upload_mesh(info.session_id(), mesh.bytes, mesh.format, mesh.name, loaded);
      !s.is_ok()) {
    std::cerr << "upload failed: " << s.to_string() << "\n";
    return;
  }
  auto stream = b.subscribe(info.session_id(), loaded.session().version());
  v1::Point3 near;
  near.set_x(mesh.near[0]);
  near.set_y(mesh.near[1]);
  near.set_z(mesh.near[2]);
  std::vector<double> total, fill_only, undo;
  std::uint32_t boundary = 0;
  for (int i = 0; i < iterations + 5; ++i) {
    const auto start = Clock::now();
    v1::FillHolesRequest fill;
    fill.set_session_id(info.session_id());
    if (select_first) {
      v1::FindNearestHoleResponse nearest;
      a.find_nearest_hole(info.session_id(), near, nearest);
      boundary = nearest.hole().boundary_edges();
      fill.mutable_selection()->mutable_ids()->add_ids(nearest.hole().id());
    } else {
      *fill.mutable_selection()->mutable_near() = near;
    }
    v1::EditResponse edit;
    const auto fill_start = Clock::now();
    if (auto s = a.fill_holes(fill, edit); !s.is_ok()) {
      std::cerr << "fill failed: " << s.to_string() << "\n";
      return;
    }
    const auto fill_end = Clock::now();
    if (!select_first && edit.report().holes_size() == 1)
      boundary = edit.report().holes(0).boundary_vertices();
    v1::SessionEvent event;
    while (stream->read(event, 10s)) {
      if (event.has_delta() && event.delta().version() == edit.version()) break;
    }
    const auto end = Clock::now();
    if (i >= 5) {  // warm-up
      total.push_back(std::chrono::duration<double, std::milli>(end - start).count());
      fill_only.push_back(std::chrono::duration<double, std::milli>(fill_end - fill_start).count());
    }
    v1::EditResponse undone;
    const auto undo_start = Clock::now();
    a.undo(info.session_id(), undone);
    while (stream->read(event, 10s)) {
      if (event.has_delta() && event.delta().version() == undone.version()) break;
    }
    if (i >= 5)
      undo.push_back(std::chrono::duration<double, std::milli>(Clock::now() - undo_start).count());
  }
  std::cout << fmt::format(
      "round trip, {}-vertex hole in {} ({} faces), {}:\n  select -> fill -> delta at a 2nd "
      "client: {}\n",
      boundary, mesh.name, mesh.faces,
      select_first ? "FindNearestHole then FillHoles{ids}" : "one FillHoles{near point} call",
      percentiles(total));
  std::cout << fmt::format("  of which the FillHoles call:              {}\n",
                           percentiles(fill_only));
  std::cout << fmt::format("  undo -> delta at the 2nd client:          {}\n", percentiles(undo));
}

void push_down(const ServerProcess& server, int iterations) {
  auto channel_a = server.connect();
  auto channel_b = server.connect();
  net::RepairClient a(channel_a), b(channel_b);
  v1::SessionInfo info;
  a.create_session("push-down bench", info);
  constexpr int kCells = 64;
  const geometry::MeshSoup soup =
      cube_with_hole(kCells, geometry::Vec3(kCells, kCells / 2, kCells), 6.5);
  const std::string off = to_off(soup);
  v1::LoadMeshResponse loaded;
  if (auto s = a.upload_mesh(info.session_id(), off, v1::OFF, "cube64.off", loaded); !s.is_ok()) {
    std::cerr << "upload failed: " << s.to_string() << "\n";
    return;
  }
  net::SessionReplica replica(b, info.session_id());
  if (!replica.start().is_ok()) return;
  v1::FillHolesRequest fill;
  fill.set_session_id(info.session_id());
  fill.mutable_selection()->set_all(true);
  fill.mutable_options()->set_shape(v1::PATCH_SHAPE_FAIR);
  // Without crease retaining: the pushes are to restore the edge a rounded fill lost.
  fill.mutable_options()->set_sharp(v1::SHARP_OFF);
  v1::EditResponse filled;
  a.fill_holes(fill, filled);
  v1::SharpEdgeRequest request;
  request.set_session_id(info.session_id());
  for (const double y :
       {kCells / 2 - 10.0, kCells / 2 - 6.0, kCells / 2 + 6.0, kCells / 2 + 10.0}) {
    auto* p = request.mutable_begin()->add_points();
    p->set_x(kCells);
    p->set_y(y);
    p->set_z(kCells);
  }
  v1::SharpEdgeResponse response;
  if (auto s = a.sharp_edge(request, response); !s.is_ok()) {
    std::cerr << "begin failed: " << s.to_string() << "\n";
    return;
  }
  request.set_confirm(true);
  if (auto s = a.sharp_edge(request, response); !s.is_ok()) {
    std::cerr << "confirm failed: " << s.to_string() << "\n";
    return;
  }
  replica.wait_for_version(response.version(), 10s);
  const std::uint32_t curtain = response.curtain_vertices();
  std::vector<double> latency;
  for (int i = 0; i < iterations + 5; ++i) {
    // The curtain vertex (on x = z, under the edge) nearest the edge's middle.
    const rpc::MeshDocument& doc = replica.document();
    std::optional<std::array<double, 3>> target;
    for (std::size_t v = 0; v < doc.positions.size(); ++v) {
      const auto& p = doc.positions[v];
      if (doc.vertex_alive[v] && std::abs(p[0] - p[2]) < 1e-9 && p[0] > kCells - 8 &&
          p[0] < kCells - 1e-9 &&
          (!target || std::abs(p[1] - kCells / 2) < std::abs((*target)[1] - kCells / 2)))
        target = p;
    }
    if (!target) break;
    const v1::SharpEdgeRequest push = sharp_edge_push(info.session_id(), *target, 0.002, 0.002);
    const auto start = Clock::now();
    v1::SharpEdgeResponse pushed;
    if (auto s = a.sharp_edge(push, pushed); !s.is_ok()) {
      std::cerr << "push failed: " << s.to_string() << "\n";
      break;
    }
    replica.wait_for_version(pushed.version(), 10s);
    const auto end = Clock::now();
    if (i >= 5) latency.push_back(std::chrono::duration<double, std::milli>(end - start).count());
  }
  std::cout << fmt::format(
      "sharp-edge push-down, {} faces, {} curtain vertices:\n  tool sample -> move delta at a 2nd "
      "client: {}\n",
      soup.triangles.size(), curtain, percentiles(latency));
}

void sweep(const ServerProcess& server, pid_t pid, int clients, double seconds) {
  auto owner_channel = server.connect();
  net::RepairClient owner(owner_channel);
  v1::SessionInfo info;
  owner.create_session("sweep", info);
  v1::LoadMeshResponse loaded;
  owner.upload_mesh(info.session_id(), annulus_off(64), v1::OFF, "annulus.off", loaded);
  struct Client {
    std::shared_ptr<net::Channel> channel;
    std::unique_ptr<net::RepairClient> api;
    std::unique_ptr<net::Stream> stream;
    std::uint64_t sent = 0;
  };
  std::vector<Client> all(static_cast<std::size_t>(clients));
  for (auto& c : all) {
    c.channel = server.connect();
    c.api = std::make_unique<net::RepairClient>(c.channel);
    c.stream = c.api->interact();
  }
  const ProcessUsage before = usage_of(pid);
  const auto start = Clock::now();
  // Open loop: one sample per client per millisecond on a fixed schedule (no coordinated
  // omission: a late tick sends its samples late, it does not skip them).
  auto next = start;
  std::uint64_t seq = 0;
  std::uint64_t late_ticks = 0;
  while (Clock::now() - start < std::chrono::duration<double>(seconds)) {
    ++seq;
    for (auto& c : all) {
      v1::InteractionMessage m;
      if (seq == 1) m.set_session_id(info.session_id());
      auto* tool = m.mutable_tool();
      tool->set_seq(seq);
      tool->set_time_us(
          std::chrono::duration_cast<std::chrono::microseconds>(Clock::now() - start).count());
      tool->mutable_position()->set_x(10.0 * std::cos(seq * 0.001));
      tool->mutable_position()->set_y(10.0 * std::sin(seq * 0.001));
      tool->mutable_direction()->set_z(-1);
      tool->set_radius(0.2);
      tool->set_stroke_begin(seq == 1);
      c.stream->send(m);
      ++c.sent;
    }
    next += 1ms;
    if (Clock::now() > next + 1ms) ++late_ticks;
    std::this_thread::sleep_until(next);
  }
  std::uint64_t sent = 0, received = 0, conflated = 0;
  for (auto& c : all) {
    c.stream->half_close();
    v1::InteractionEvent event;
    v1::InteractionAck last;
    while (c.stream->read(event, 30s)) {
      if (event.has_ack()) last = event.ack();
    }
    sent += c.sent;
    received += last.tool_samples_received();
    conflated += last.tool_samples_conflated();
  }
  const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
  const ProcessUsage after = usage_of(pid);
  std::cout << fmt::format(
      "sweep {:>2} clients x 1 kHz for {:.0f} s: sent {} received {} dropped {} conflated {} | "
      "server CPU {:.0f}% of "
      "one core, RSS {:.1f} MiB (peak {:.1f}) | sender late ticks {}\n",
      clients, elapsed, sent, received, sent - received, conflated,
      100 * (after.cpu_seconds - before.cpu_seconds) / elapsed, after.rss_mib, after.peak_rss_mib,
      late_ticks);
}

//! Open file descriptors of \p pid.
std::size_t open_fds(pid_t pid) {
  std::error_code ec;
  std::size_t n = 0;
  for (auto it = std::filesystem::directory_iterator("/proc/" + std::to_string(pid) + "/fd", ec);
       !ec && it != std::filesystem::directory_iterator(); it.increment(ec))
    ++n;
  return n;
}

//! SERVICE.md §5.3's soak: for \p seconds, cycles of what `touchmend --server ... fill` does
//! per file (connect, create a session, upload the annulus, list its holes, fill, undo, fill
//! again, export, close the session, disconnect) plus a subscriber on each session; the server's
//! RSS and open descriptors after the first tenth (warm-up) and at the end.
void soak(const ServerProcess& server, pid_t pid, double seconds) {
  const std::string mesh = annulus_off(300);
  const auto start = Clock::now();
  const auto warm_until = start + std::chrono::duration<double>(seconds / 10);
  const auto end = start + std::chrono::duration<double>(seconds);
  std::optional<ProcessUsage> warm;
  std::size_t warm_fds = 0;
  std::size_t cycles = 0, failures = 0;
  std::vector<double> cycle_ms;
  while (Clock::now() < end) {
    const auto cycle_start = Clock::now();
    auto channel = server.connect();
    if (!channel) {
      ++failures;
      continue;
    }
    net::RepairClient client(channel);
    v1::SessionInfo info;
    v1::LoadMeshResponse loaded;
    v1::ListHolesResponse holes;
    v1::EditResponse edit;
    std::string exported;
    bool ok = client.create_session("soak", info).is_ok() &&
              client.upload_mesh(info.session_id(), mesh, v1::OFF, "soak.off", loaded).is_ok();
    auto watcher = ok ? client.subscribe(info.session_id(), loaded.session().version()) : nullptr;
    ok = ok && client.list_holes(info.session_id(), holes).is_ok() && holes.holes_size() > 0;
    if (ok) {
      v1::FillHolesRequest fill;
      fill.set_session_id(info.session_id());
      fill.mutable_selection()->mutable_ids()->add_ids(holes.holes(0).id());
      ok = client.fill_holes(fill, edit).is_ok() && client.undo(info.session_id(), edit).is_ok() &&
           client.fill_holes(fill, edit).is_ok() &&
           client.export_mesh(info.session_id(), v1::OFF, false, exported).is_ok();
    }
    if (watcher) watcher->cancel();
    if (!info.session_id().empty()) ok = client.close_session(info.session_id()).is_ok() && ok;
    failures += !ok;
    ++cycles;
    cycle_ms.push_back(
        std::chrono::duration<double, std::milli>(Clock::now() - cycle_start).count());
    if (!warm && Clock::now() >= warm_until) {
      std::this_thread::sleep_for(100ms);  // the connection just closed is gone
      warm = usage_of(pid);
      warm_fds = open_fds(pid);
    }
  }
  std::this_thread::sleep_for(200ms);
  const ProcessUsage last = usage_of(pid);
  const std::size_t last_fds = open_fds(pid);
  const double growth = warm ? 100 * (last.rss_mib - warm->rss_mib) / warm->rss_mib : 0;
  std::cout << fmt::format(
      "soak {:.0f} s: {} cycles ({} failed), cycle {}\n  server RSS {:.1f} MiB after the "
      "warm-up, {:.1f} MiB at the end ({:+.1f}%; target < 5%), peak {:.1f} MiB; open files {} "
      "-> {}\n",
      seconds, cycles, failures, percentiles(cycle_ms), warm ? warm->rss_mib : 0.0, last.rss_mib,
      growth, last.peak_rss_mib, warm_fds, last_fds);
}

void batch(const ServerProcess& server) {
  auto channel = server.connect();
  net::RepairClient client(channel);
  std::vector<std::string> ids;
  const auto start = Clock::now();
  std::size_t bytes = 0;
  for (const std::string& name : list_cases()) {
    const std::string path = shared_data_dir() + "/cases/" + name + "/holed.off";
    std::ifstream in(path, std::ios::binary);
    if (!in) continue;
    std::string mesh((std::istreambuf_iterator<char>(in)), {});
    bytes += mesh.size();
    v1::JobSpec spec;
    spec.set_format(v1::OFF);
    spec.set_name(name);
    spec.mutable_selection()->set_all(true);
    v1::Job job;
    if (auto s = client.submit_job(spec, mesh, job); s.is_ok()) ids.push_back(job.job_id());
  }
  std::size_t succeeded = 0;
  for (const auto& id : ids) {
    auto w = client.watch_job(id);
    v1::Job j;
    while (w->read(j, 600s)) {
    }
    succeeded += j.state() == v1::SUCCEEDED;
  }
  const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
  std::cout << fmt::format(
      "batch: {} jobs ({} succeeded, {:.1f} MB of meshes) in {:.2f} s: {:.1f} jobs/s\n", ids.size(),
      succeeded, bytes / 1e6, elapsed, ids.size() / elapsed);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"touchmend-service-bench: service latency, streaming and throughput on loopback"};
  int iterations = 200;
  double sweep_seconds = 30;
  std::vector<int> sweep_clients = {1, 8, 32};
  bool skip_sweep = false;
  app.add_option("--iterations", iterations, "Round trips to measure")->capture_default_str();
  app.add_option("--sweep-seconds", sweep_seconds, "Duration of each sweep run")
      ->capture_default_str();
  app.add_option("--sweep-clients", sweep_clients, "Client counts for the sweep runs")
      ->capture_default_str();
  app.add_flag("--skip-sweep", skip_sweep, "Only the round trip and the batch");
  double soak_seconds = 0;
  app.add_option("--soak", soak_seconds,
                 "Only the soak, for this many seconds: cycles of connect, create a session, "
                 "upload, list holes, fill, undo, fill, export, close, disconnect (with a "
                 "subscriber); the server's RSS growth after a tenth of the time, and its open "
                 "files")
      ->check(CLI::NonNegativeNumber);
  std::string mesh_path;
  std::vector<double> near;
  app.add_option("--mesh", mesh_path,
                 "Measure only the round trips, on this mesh (OFF, OBJ, PLY or STL) instead of "
                 "the 3,600-face annulus: the hole filled is the one nearest --near");
  app.add_option("--near", near, "With --mesh: the point the hole is picked near (X Y Z)")
      ->expected(3);
  CLI11_PARSE(app, argc, argv);
  RoundTripMesh trip = annulus_round_trip();
  if (!mesh_path.empty()) {
    if (near.size() != 3) {
      std::cerr << "--mesh needs --near X Y Z\n";
      return 2;
    }
    const geometry::ReadResult read = geometry::read_mesh_file(mesh_path);
    if (!read.ok) {
      std::cerr << mesh_path << ": " << read.error << "\n";
      return 1;
    }
    std::ifstream in(mesh_path, std::ios::binary);
    trip.bytes.assign(std::istreambuf_iterator<char>(in), {});
    cli::wire_format(mesh_path, trip.format);  // the reader knew the extension
    trip.name = std::filesystem::path(mesh_path).filename().string();
    trip.near = {near[0], near[1], near[2]};
    trip.faces = read.soup.triangles.size();
  }

  TempDir dir;
  ServerProcess server(dir.path());
  if (!server.start()) {
    std::cerr << "could not start touchmend-server\n" << server.log();
    return 1;
  }
  std::cout << fmt::format("machine: {} cores; server {}\n", std::thread::hardware_concurrency(),
                           TOUCHMEND_SERVER_PATH);
  if (soak_seconds > 0) {
    soak(server, server.pid(), soak_seconds);
    return 0;
  }
  round_trip(server, iterations, false, trip);
  round_trip(server, iterations, true, trip);
  if (!mesh_path.empty()) return 0;
  push_down(server, std::max(iterations, 500));
  if (!skip_sweep) {
    for (int n : sweep_clients) sweep(server, server.pid(), n, sweep_seconds);
  }
  batch(server);
  return 0;
}
