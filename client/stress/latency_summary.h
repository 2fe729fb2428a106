// Percentiles of request latencies (nearest-rank, so every reported value is
// a latency that was actually measured).
#pragma once

#include <cstdint>
#include <vector>

namespace pbgi::stress {

struct LatencySummary {
  uint64_t count = 0;
  double min_ms = 0, mean_ms = 0, p50_ms = 0, p95_ms = 0, p99_ms = 0, max_ms = 0;
};

// The nearest-rank percentile p in [0, 100] of `sorted_ms` (ascending,
// non-empty): the smallest value with at least p% of the values <= it.
double percentile(const std::vector<double>& sorted_ms, double p);

// Summary of `latencies_ms` in any order (sorted in place); all zero if empty.
LatencySummary summarize_latencies(std::vector<double>& latencies_ms);

}  // namespace pbgi::stress
