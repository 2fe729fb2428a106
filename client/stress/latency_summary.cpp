#include "client/stress/latency_summary.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace pbgi::stress {

double percentile(const std::vector<double>& sorted_ms, double p) {
  if (sorted_ms.empty()) return 0;
  const double n = static_cast<double>(sorted_ms.size());
  // Rank ceil(p/100 * n), 1-based, clamped to [1, n].
  const double rank = std::clamp(std::ceil(p / 100.0 * n), 1.0, n);
  return sorted_ms[static_cast<size_t>(rank) - 1];
}

LatencySummary summarize_latencies(std::vector<double>& latencies_ms) {
  LatencySummary s;
  if (latencies_ms.empty()) return s;
  std::sort(latencies_ms.begin(), latencies_ms.end());
  s.count = latencies_ms.size();
  s.min_ms = latencies_ms.front();
  s.max_ms = latencies_ms.back();
  s.mean_ms = std::accumulate(latencies_ms.begin(), latencies_ms.end(), 0.0) / s.count;
  s.p50_ms = percentile(latencies_ms, 50);
  s.p95_ms = percentile(latencies_ms, 95);
  s.p99_ms = percentile(latencies_ms, 99);
  return s;
}

}  // namespace pbgi::stress
