#pragma once

//! \file metrics.h
//! \brief Server counters and latency histograms, rendered in the Prometheus text format
//! 0.0.4 (SERVICE.md §6.2: `touchmend_` prefix, base units, `_total` counters, no per-session
//! labels). Lock-free on the hot paths: atomics only.

#include <array>
#include <atomic>
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

namespace touchmend::service {

class Histogram {
 public:
  //! Bucket upper bounds in seconds.
  static constexpr std::array<double, 14> kBounds = {
      0.0001, 0.00025, 0.0005, 0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1.0, 5.0};
  void observe(double seconds);
  //! Appends `name_bucket{...}`, `name_sum`, `name_count` lines with \p labels.
  void render(const std::string& name, const std::string& labels, std::string& out) const;

 private:
  std::array<std::atomic<std::uint64_t>, kBounds.size() + 1> counts_{};
  std::atomic<std::uint64_t> sum_ns_{0};
};

struct MethodMetrics {
  std::atomic<std::uint64_t> started{0};
  std::atomic<std::uint64_t> ok{0};
  std::atomic<std::uint64_t> failed{0};
  Histogram latency;
};

class Metrics {
 public:
  Metrics();

  std::atomic<std::int64_t> connections_open{0};
  std::atomic<std::int64_t> calls_alive{0};  //!< ServerCall objects in memory
  std::atomic<std::uint64_t> connections_accepted{0};
  std::atomic<std::uint64_t> connections_rejected{0};
  std::atomic<std::uint64_t> frames_received{0};
  std::atomic<std::uint64_t> frames_sent{0};
  std::atomic<std::uint64_t> bytes_received{0};
  std::atomic<std::uint64_t> bytes_sent{0};
  std::atomic<std::uint64_t> protocol_errors{0};
  std::atomic<std::uint64_t> auth_failures{0};
  std::atomic<std::uint64_t> deltas_dropped{0};
  std::atomic<std::uint64_t> slow_consumer_resyncs{0};
  std::atomic<std::uint64_t> slow_consumer_disconnects{0};
  std::atomic<std::uint64_t> call_rate_disconnects{0};
  std::atomic<std::uint64_t> tool_samples{0};
  std::atomic<std::uint64_t> tool_samples_conflated{0};
  std::atomic<std::uint64_t> jobs_submitted{0};
  std::atomic<std::uint64_t> jobs_rejected_busy{0};
  Histogram journal_commit;
  Histogram job_duration;

  //! Per-method counters; unknown names are counted under "unknown".
  MethodMetrics& method(const std::string& full_name);

  //! Gauges read at render time (sessions, queue depth...): name -> value.
  void add_gauge(std::string name, std::string help, std::function<double()> read);

  std::string render() const;

 private:
  std::map<std::string, MethodMetrics> methods_;  // fixed at construction: never rehashed
  struct Gauge {
    std::string name, help;
    std::function<double()> read;
  };
  std::vector<Gauge> gauges_;
};

}  // namespace touchmend::service
