// pbgid's metrics in the Prometheus text exposition format (version 0.0.4),
// served by the daemon's optional HTTP port (server/daemon/metrics_http.h).
#pragma once

#include "pbgi/v1/pbgi.pb.h"
#include "server/service/request_metrics.h"

#include <string>

namespace pbgi::service {

// Metric families (all prefixed pbgi_):
//   requests_total{rpc,code}            counter
//   request_duration_seconds{rpc}       histogram
//   requests_in_flight, requests_queued gauges; requests_rejected_total counter
//   cache_hits_total, cache_misses_total, cache_evictions_total,
//   cache_read_bytes_total              counters
//   cache_bytes, cache_pinned_bytes, cache_budget_bytes,
//   resident_memory_bytes                                    gauges
//   memory_budget_bytes, memory_request_reserve_bytes,
//   memory_page_cache_floor_bytes                            gauges
//   memory_charged_bytes{kind="scenes"|"reading"|"builds"}   gauge
//   memory_refusals_total                                    counter
//     (the memory_ families only when status has a MemoryStatus)
//   scenes_open, scene_memory_bytes{scene_id}                gauges
//   scene_build_progress{scene_path,stage}                   gauge (0..1)
//   uptime_seconds                                           gauge
std::string prometheus_text(const v1::GetStatusResponse& status,
                            const RequestMetricsSnapshot& requests);

}  // namespace pbgi::service
