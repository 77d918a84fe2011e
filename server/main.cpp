// touchmend-server — the headless repair server: sessions, fills, live deltas, fill jobs.

#include <boost/asio.hpp>
#include <csignal>
#include <fcntl.h>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sys/file.h>
#include <thread>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <OpenMesh/Core/System/omstream.hh>

#include "server/service/admin_http.h"
#include "server/service/auth.h"
#include "server/service/jobs.h"
#include "server/service/log.h"
#include "server/service/repair_service.h"
#include "server/service/rpc_server.h"
#include "server/service/store.h"

namespace asio = boost::asio;
using tcp = asio::ip::tcp;
using namespace touchmend::service;

namespace {

bool parse_endpoint(const std::string& text, tcp::endpoint& out, std::string& error) {
  const auto colon = text.rfind(':');
  if (colon == std::string::npos) {
    error = "expected HOST:PORT, got '" + text + "'";
    return false;
  }
  std::string host = text.substr(0, colon);
  if (host.size() >= 2 && host.front() == '[' && host.back() == ']')
    host = host.substr(1, host.size() - 2);
  unsigned long port = 0;
  try {
    std::size_t used = 0;
    port = std::stoul(text.substr(colon + 1), &used);
    if (used != text.size() - colon - 1 || port > 65535) throw std::out_of_range("port");
  } catch (const std::exception&) {
    error = "bad port in '" + text + "'";
    return false;
  }
  boost::system::error_code ec;
  auto address = asio::ip::make_address(host == "localhost" ? "127.0.0.1" : host, ec);
  if (ec) {
    error = "bad address '" + host + "' (use a numeric IPv4/IPv6 address)";
    return false;
  }
  out = tcp::endpoint(address, static_cast<unsigned short>(port));
  return true;
}

// Atomic small-file write (temporary + rename) for the port file.
bool write_file_atomically(const std::string& path, const std::string& text) {
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::trunc);
    if (!(out << text)) return false;
  }
  return std::rename(tmp.c_str(), path.c_str()) == 0;
}

}  // namespace

int main(int argc, char** argv) {
  omerr().disable();
  omout().disable();
  omlog().disable();

  CLI::App app{
      "touchmend-server: the headless mesh-repair server. Holds meshes in repair sessions that\n"
      "several clients share (edits reach every subscriber as versioned deltas), runs every\n"
      "geometric algorithm, accepts fill jobs from automated clients, and journals every edit\n"
      "to an embedded SQLite store before acknowledging it, so a killed server loses nothing\n"
      "acknowledged. Wire protocol: proto/README.md."};
  app.set_version_flag("--version", "touchmend-server 0.1.0");
  std::string listen = "127.0.0.1:7878";
  std::string data_dir = "touchmend-data";
  std::string tls_cert, tls_key, tokens_file, metrics_address, port_file, log_level = "info";
  unsigned workers = std::max(2u, std::thread::hardware_concurrency());
  unsigned io_threads = 2;
  unsigned job_workers = 1;
  unsigned job_queue = 64;
  unsigned job_ttl_hours = 24;
  unsigned max_upload_mb = 256;
  unsigned hello_timeout_ms = 10'000;
  unsigned keepalive_timeout_ms = 20'000;
  unsigned max_call_rate = 5'000;
  unsigned max_frame_kb = 1024;
  unsigned queue_soft_kb = 4096;
  unsigned queue_hard_kb = 16384;
  unsigned socket_send_buffer_kb = 1024;
  app.add_option("--listen", listen,
                 "Address and port to serve on (HOST:PORT; port 0 picks a free one)")
      ->capture_default_str();
  app.add_option("--data-dir", data_dir, "Directory for the store (created if missing)")
      ->capture_default_str();
  auto* cert = app.add_option("--tls-cert", tls_cert,
                              "PEM certificate chain: serve TLS instead of plain TCP");
  auto* key = app.add_option("--tls-key", tls_key, "PEM private key of --tls-cert");
  cert->needs(key);
  key->needs(cert);
  app.add_option("--tokens", tokens_file,
                 "File of 'PRINCIPAL TOKEN' lines; every client must present one. Without it the\n"
                 "server accepts loopback clients only and refuses a non-loopback --listen");
  app.add_option("--workers", workers, "Worker threads for session work (fills, holes, exports)")
      ->capture_default_str()
      ->check(CLI::Range(1, 256));
  app.add_option("--io-threads", io_threads, "Network threads")
      ->capture_default_str()
      ->check(CLI::Range(1, 64));
  app.add_option("--metrics", metrics_address,
                 "HOST:PORT for /metrics (Prometheus), /healthz and /readyz over HTTP");
  app.add_option("--job-workers", job_workers, "Threads running fill jobs")
      ->capture_default_str()
      ->check(CLI::Range(1, 64));
  app.add_option("--job-queue", job_queue, "Queued jobs before submissions are refused as busy")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));
  app.add_option("--job-ttl-hours", job_ttl_hours, "How long finished jobs and results are kept")
      ->capture_default_str()
      ->check(CLI::Range(1, 24 * 365));
  app.add_option("--max-upload-mb", max_upload_mb, "Largest mesh accepted")
      ->capture_default_str()
      ->check(CLI::Range(1, 4096));
  app.add_option("--max-frame-kb", max_frame_kb, "Largest frame accepted")
      ->capture_default_str()
      ->check(CLI::Range(64, 16384));
  app.add_option("--queue-soft-kb", queue_soft_kb,
                 "Per-connection outbound queue above which live events to a slow subscriber are\n"
                 "dropped (it gets a resync notice once it catches up)")
      ->capture_default_str()
      ->check(CLI::Range(16, 1 << 20));
  app.add_option("--queue-hard-kb", queue_hard_kb,
                 "Per-connection outbound queue above which the connection is closed")
      ->capture_default_str()
      ->check(CLI::Range(32, 1 << 21));
  app.add_option(
         "--socket-send-buffer-kb", socket_send_buffer_kb,
         "Kernel send buffer per connection (bounds what a slow reader holds in the kernel)")
      ->capture_default_str()
      ->check(CLI::Range(4, 1 << 16));
  app.add_option("--hello-timeout-ms", hello_timeout_ms,
                 "A connection must authenticate within this")
      ->capture_default_str()
      ->check(CLI::Range(100, 600000));
  app.add_option("--keepalive-timeout-ms", keepalive_timeout_ms,
                 "Close a connection silent for this long (one that stops reading is given "
                 "as long, and at least 30 s)")
      ->capture_default_str()
      ->check(CLI::Range(500, 3600000));
  app.add_option(
         "--max-call-rate", max_call_rate,
         "Calls a connection may start per second (bursts of twice as many): a client past\n"
         "it, such as an open/cancel storm, gets GOAWAY RESOURCE_EXHAUSTED and is closed")
      ->capture_default_str()
      ->check(CLI::Range(10, 1'000'000));
  app.add_option("--port-file", port_file,
                 "Write the bound port(s) here once listening (for scripts)");
  app.add_option("--log-level", log_level, "trace, debug, info, warn, error")
      ->capture_default_str()
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error"}));
  CLI11_PARSE(app, argc, argv);

  init_logging(log_level);
  auto fail = [](const std::string& message) {
    std::cerr << "touchmend-server: " << message << "\n";
    return 1;
  };

  tcp::endpoint endpoint;
  std::string error;
  if (!parse_endpoint(listen, endpoint, error)) return fail("--listen: " + error);
  TokenAuthenticator auth;
  if (!tokens_file.empty()) {
    if (Status s = TokenAuthenticator::from_file(tokens_file, auth); !s.is_ok())
      return fail(s.message);
  } else if (!endpoint.address().is_loopback()) {
    return fail("refusing to listen on non-loopback " + listen +
                " without --tokens (anyone could reach the sessions); add --tokens FILE");
  }
  std::optional<tcp::endpoint> metrics_endpoint;
  if (!metrics_address.empty()) {
    tcp::endpoint e;
    if (!parse_endpoint(metrics_address, e, error)) return fail("--metrics: " + error);
    metrics_endpoint = e;
  }

  std::error_code fs_error;
  std::filesystem::create_directories(data_dir, fs_error);
  if (fs_error) return fail("cannot create data dir " + data_dir + ": " + fs_error.message());
  // One server per data dir: a second one would interleave journals.
  const std::string lock_path = (std::filesystem::path(data_dir) / ".lock").string();
  const int lock_fd = ::open(lock_path.c_str(), O_CREAT | O_RDWR | O_CLOEXEC, 0644);
  if (lock_fd < 0 || ::flock(lock_fd, LOCK_EX | LOCK_NB) != 0) {
    return fail("data dir " + data_dir + " is in use by another touchmend-server");
  }

  Status status;
  auto store = Store::open(std::filesystem::path(data_dir) / "touchmend.db", status);
  if (!store) return fail(status.message);

  Metrics metrics;
  MeshLimits limits;
  limits.max_upload_bytes = std::size_t{max_upload_mb} << 20;
  JobOptions job_options;
  job_options.workers = job_workers;
  job_options.max_queued = job_queue;
  job_options.result_ttl = std::chrono::hours(job_ttl_hours);
  job_options.limits = limits;
  JobManager jobs(*store, metrics, job_options);

  asio::thread_pool pool(workers);
  ServiceOptions service_options;
  service_options.data_dir = data_dir;
  service_options.session.limits = limits;
  RepairService service(*store, jobs, pool, metrics, service_options);
  const auto recovery_start = std::chrono::steady_clock::now();
  if (Status s = service.recover(); !s.is_ok()) return fail("recovery failed: " + s.message);
  if (Status s = jobs.start(); !s.is_ok()) return fail(s.message);
  log_event(
      spdlog::level::info, "recovered",
      {{"duration_s",
        std::chrono::duration<double>(std::chrono::steady_clock::now() - recovery_start).count()},
       {"sessions", service.session_count()}});

  metrics.add_gauge("touchmend_sessions_active", "Sessions held by this server",
                    [&] { return static_cast<double>(service.session_count()); });
  metrics.add_gauge("touchmend_jobs_queued", "Fill jobs waiting for a worker",
                    [&] { return static_cast<double>(jobs.queued()); });
  metrics.add_gauge("touchmend_jobs_running", "Fill jobs running",
                    [&] { return static_cast<double>(jobs.running()); });
  metrics.add_gauge("touchmend_journal_last_commit_seconds", "Duration of the last journal commit",
                    [&] { return store->last_commit_seconds(); });
  metrics.add_gauge("touchmend_store_background_checkpoints",
                    "Checkpoints of the store's write-ahead log made beside the journal commits",
                    [&] { return static_cast<double>(store->background_checkpoints()); });
  metrics.add_gauge(
      "touchmend_store_health",
      "Whether the store takes writes: 0 yes, 1 its disk is full (edits refused until "
      "space is freed), 2 failed (fail-stop until a restart)",
      [&] { return static_cast<double>(store->condition().health); });
  metrics.add_gauge("touchmend_store_disk_full_refusals",
                    "Writes the store refused because its disk was full",
                    [&] { return static_cast<double>(store->disk_full_refusals()); });

  asio::io_context io;
  ConnectionLimits connection_limits;
  connection_limits.max_frame_bytes = std::size_t{max_frame_kb} << 10;
  connection_limits.hello_timeout = std::chrono::milliseconds(hello_timeout_ms);
  connection_limits.soft_queue_bytes = std::size_t{queue_soft_kb} << 10;
  connection_limits.socket_send_buffer_bytes = std::size_t{socket_send_buffer_kb} << 10;
  connection_limits.hard_queue_bytes = std::max<std::size_t>(
      std::size_t{queue_hard_kb} << 10, connection_limits.soft_queue_bytes * 2);
  connection_limits.keepalive_timeout = std::chrono::milliseconds(keepalive_timeout_ms);
  connection_limits.max_call_rate = max_call_rate;
  connection_limits.max_call_burst = 2.0 * max_call_rate;
  connection_limits.ping_interval =
      std::min(connection_limits.ping_interval, connection_limits.keepalive_timeout / 4);
  RpcServer server(io, service, auth, metrics, connection_limits);
  std::optional<TlsConfig> tls;
  if (!tls_cert.empty()) tls = TlsConfig{tls_cert, tls_key};
  if (Status s = server.listen(endpoint, tls); !s.is_ok()) return fail(s.message);

  std::unique_ptr<AdminHttpServer> admin;
  if (metrics_endpoint) {
    admin =
        std::make_unique<AdminHttpServer>(io, metrics, [&] { return store->condition().reason; });
    if (Status s = admin->listen(*metrics_endpoint); !s.is_ok()) return fail(s.message);
  }

  const auto bound = server.local_endpoint();
  log_event(spdlog::level::info, "listening",
            {{"address", bound.address().to_string()},
             {"port", bound.port()},
             {"tls", tls.has_value()},
             {"tokens", auth.requires_tokens()},
             {"data_dir", data_dir},
             {"workers", workers},
             {"metrics_port", admin ? admin->local_endpoint().port() : 0}});
  if (!port_file.empty()) {
    std::string text = std::to_string(bound.port()) + "\n";
    if (admin) text += std::to_string(admin->local_endpoint().port()) + "\n";
    if (!write_file_atomically(port_file, text))
      return fail("cannot write --port-file " + port_file);
  }

  // Finished jobs past their TTL are removed once a minute.
  asio::steady_timer expiry(io);
  std::function<void()> schedule_expiry = [&] {
    expiry.expires_after(std::chrono::minutes(1));
    expiry.async_wait([&](const boost::system::error_code& ec) {
      if (ec) return;
      jobs.expire();
      schedule_expiry();
    });
  };
  jobs.expire();
  schedule_expiry();

  asio::signal_set signals(io, SIGINT, SIGTERM);
  asio::steady_timer drain(io);
  signals.async_wait([&](const boost::system::error_code& ec, int signal) {
    if (ec) return;
    log_event(spdlog::level::info, "shutting_down", {{"signal", signal}});
    server.shutdown({touchmend::rpc::StatusCode::Unavailable, "the server is shutting down"});
    if (admin) admin->stop();
    expiry.cancel();
    // Give the GOAWAY frames a moment to leave, then stop the loop.
    drain.expires_after(std::chrono::milliseconds(200));
    drain.async_wait([&](const boost::system::error_code&) { io.stop(); });
  });

  std::vector<std::thread> threads;
  for (unsigned i = 1; i < io_threads; ++i) threads.emplace_back([&] { io.run(); });
  io.run();
  for (auto& t : threads) t.join();

  jobs.stop();
  service.snapshot_all();
  pool.join();
  log_event(spdlog::level::info, "stopped");
  return 0;
}
