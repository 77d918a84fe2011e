#include "server/service/metrics.h"

#include <fmt/format.h>

#include "proto/rpc/method_table.h"

namespace touchmend::service {

void Histogram::observe(double seconds) {
  std::size_t i = 0;
  while (i < kBounds.size() && seconds > kBounds[i]) ++i;
  counts_[i].fetch_add(1, std::memory_order_relaxed);
  sum_ns_.fetch_add(static_cast<std::uint64_t>(seconds * 1e9), std::memory_order_relaxed);
}

void Histogram::render(const std::string& name, const std::string& labels, std::string& out) const {
  const std::string sep = labels.empty() ? "" : ",";
  std::uint64_t cumulative = 0;
  for (std::size_t i = 0; i < kBounds.size(); ++i) {
    cumulative += counts_[i].load(std::memory_order_relaxed);
    out +=
        fmt::format("{}_bucket{{{}{}le=\"{}\"}} {}\n", name, labels, sep, kBounds[i], cumulative);
  }
  cumulative += counts_[kBounds.size()].load(std::memory_order_relaxed);
  out += fmt::format("{}_bucket{{{}{}le=\"+Inf\"}} {}\n", name, labels, sep, cumulative);
  const std::string braces = labels.empty() ? "" : "{" + labels + "}";
  out += fmt::format("{}_sum{} {}\n", name, braces, sum_ns_.load(std::memory_order_relaxed) * 1e-9);
  out += fmt::format("{}_count{} {}\n", name, braces, cumulative);
}

Metrics::Metrics() {
  for (const auto& m : rpc::repair_methods()) methods_[m.full_name];
  methods_["unknown"];
}

MethodMetrics& Metrics::method(const std::string& full_name) {
  auto it = methods_.find(full_name);
  return it == methods_.end() ? methods_.at("unknown") : it->second;
}

void Metrics::add_gauge(std::string name, std::string help, std::function<double()> read) {
  gauges_.push_back({std::move(name), std::move(help), std::move(read)});
}

std::string Metrics::render() const {
  std::string out;
  auto counter = [&](const char* name, const char* help, std::uint64_t value) {
    out += fmt::format("# HELP {} {}\n# TYPE {} counter\n{} {}\n", name, help, name, name, value);
  };
  auto gauge = [&](const std::string& name, const std::string& help, double value) {
    out += fmt::format("# HELP {} {}\n# TYPE {} gauge\n{} {}\n", name, help, name, name, value);
  };
  gauge("touchmend_connections", "Open client connections",
        static_cast<double>(connections_open.load()));
  gauge("touchmend_calls_alive",
        "Calls the server holds in memory: open calls and those whose last answer is on its way",
        static_cast<double>(calls_alive.load()));
  counter("touchmend_connections_accepted_total", "Connections accepted",
          connections_accepted.load());
  counter("touchmend_connections_rejected_total", "Connections refused (limits, TLS, auth)",
          connections_rejected.load());
  counter("touchmend_frames_received_total", "Frames received", frames_received.load());
  counter("touchmend_frames_sent_total", "Frames sent", frames_sent.load());
  counter("touchmend_frame_bytes_received_total", "Bytes received", bytes_received.load());
  counter("touchmend_frame_bytes_sent_total", "Bytes sent", bytes_sent.load());
  counter("touchmend_protocol_errors_total", "Malformed, oversized or unexpected frames",
          protocol_errors.load());
  counter("touchmend_auth_failures_total", "Rejected tokens and unauthorised access",
          auth_failures.load());
  counter("touchmend_deltas_dropped_total", "Deltas not sent to slow subscribers",
          deltas_dropped.load());
  counter("touchmend_slow_consumer_resyncs_total", "Resync notices sent to slow subscribers",
          slow_consumer_resyncs.load());
  counter("touchmend_slow_consumer_disconnects_total", "Connections closed for an overfull queue",
          slow_consumer_disconnects.load());
  counter("touchmend_call_rate_disconnects_total",
          "Connections closed for starting calls faster than the call rate limit",
          call_rate_disconnects.load());
  counter("touchmend_tool_samples_total", "Tool samples received", tool_samples.load());
  counter("touchmend_tool_samples_conflated_total", "Tool samples superseded before processing",
          tool_samples_conflated.load());
  counter("touchmend_jobs_submitted_total", "Fill jobs accepted", jobs_submitted.load());
  counter("touchmend_jobs_rejected_busy_total", "Fill jobs refused because the queue was full",
          jobs_rejected_busy.load());
  for (const auto& g : gauges_) gauge(g.name, g.help, g.read());

  out +=
      "# HELP touchmend_rpcs_started_total RPCs started\n# TYPE touchmend_rpcs_started_total "
      "counter\n";
  for (const auto& [name, m] : methods_) {
    out +=
        fmt::format("touchmend_rpcs_started_total{{method=\"{}\"}} {}\n", name, m.started.load());
  }
  out +=
      "# HELP touchmend_rpcs_handled_total RPCs finished, by outcome\n"
      "# TYPE touchmend_rpcs_handled_total counter\n";
  for (const auto& [name, m] : methods_) {
    out += fmt::format("touchmend_rpcs_handled_total{{method=\"{}\",code=\"OK\"}} {}\n", name,
                       m.ok.load());
    out += fmt::format("touchmend_rpcs_handled_total{{method=\"{}\",code=\"error\"}} {}\n", name,
                       m.failed.load());
  }
  out +=
      "# HELP touchmend_rpc_duration_seconds RPC latency from CALL to TRAILERS\n"
      "# TYPE touchmend_rpc_duration_seconds histogram\n";
  for (const auto& [name, m] : methods_) {
    m.latency.render("touchmend_rpc_duration_seconds", fmt::format("method=\"{}\"", name), out);
  }
  out +=
      "# HELP touchmend_journal_commit_duration_seconds Durable journal commit time\n"
      "# TYPE touchmend_journal_commit_duration_seconds histogram\n";
  journal_commit.render("touchmend_journal_commit_duration_seconds", "", out);
  out +=
      "# HELP touchmend_job_duration_seconds Fill job run time\n"
      "# TYPE touchmend_job_duration_seconds histogram\n";
  job_duration.render("touchmend_job_duration_seconds", "", out);
  return out;
}

}  // namespace touchmend::service
