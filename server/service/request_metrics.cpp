#include "server/service/request_metrics.h"

namespace pbgi::service {

void LatencyHistogram::add(double seconds) {
  for (size_t i = 0; i < kBounds.size(); ++i) {
    if (seconds <= kBounds[i]) ++buckets[i];
  }
  ++count;
  sum += seconds;
}

void RequestMetrics::record(const std::string& rpc, grpc::StatusCode code, double seconds) {
  std::lock_guard lock(mutex_);
  ++data_.calls[{rpc, code}];
  data_.latency[rpc].add(seconds);
}

RequestMetricsSnapshot RequestMetrics::snapshot() const {
  std::lock_guard lock(mutex_);
  return data_;
}


}  // namespace pbgi::service
