// Counters of the calls pbgid served, for GetStatus and the Prometheus
// endpoint: calls by RPC and status code, and a latency histogram per RPC
// (fixed buckets, Prometheus convention: cumulative counts of calls that
// took <= each bound).
#pragma once

#include <grpcpp/support/status.h>

#include <array>
#include <cstdint>
#include <map>
#include <mutex>
#include <string>
#include <utility>

namespace pbgi::service {

struct LatencyHistogram {
  // Upper bounds in seconds; the last bucket (+Inf) is count.
  static constexpr std::array<double, 13> kBounds = {0.001, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25,
                                                     0.5,   1.0,   2.5,  5.0,   10.0, 60.0};
  std::array<uint64_t, kBounds.size()> buckets{};   // cumulative
  uint64_t count = 0;
  double sum = 0;
  void add(double seconds);
};

struct RequestMetricsSnapshot {
  std::map<std::pair<std::string, grpc::StatusCode>, uint64_t> calls;
  std::map<std::string, LatencyHistogram> latency;
};

// Thread-safe.
class RequestMetrics {
 public:
  void record(const std::string& rpc, grpc::StatusCode code, double seconds);
  RequestMetricsSnapshot snapshot() const;

 private:
  mutable std::mutex mutex_;
  RequestMetricsSnapshot data_;
};

}  // namespace pbgi::service
