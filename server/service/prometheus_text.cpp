#include "server/service/prometheus_text.h"

#include "proto/status_code_name.h"

#include <fmt/format.h>

namespace pbgi::service {
namespace {

// Label values escape backslash, double quote and newline.
std::string label(const std::string& value) {
  std::string out;
  out.reserve(value.size());
  for (char c : value) {
    if (c == '\\') out += "\\\\";
    else if (c == '"') out += "\\\"";
    else if (c == '\n') out += "\\n";
    else out += c;
  }
  return out;
}

class Writer {
 public:
  void family(const char* name, const char* type, const char* help) {
    out_ += fmt::format("# HELP pbgi_{} {}\n# TYPE pbgi_{} {}\n", name, help, name, type);
  }
  void sample(const std::string& name, double value, const std::string& labels = {}) {
    out_ += fmt::format("pbgi_{}{}{}{}{} {}\n", name, labels.empty() ? "" : "{", labels,
                        labels.empty() ? "" : "}", "", value);
  }
  std::string take() { return std::move(out_); }

 private:
  std::string out_;
};

}  // namespace

std::string prometheus_text(const v1::GetStatusResponse& status,
                            const RequestMetricsSnapshot& requests) {
  Writer w;
  w.family("requests_total", "counter", "Calls served, by RPC and gRPC status code.");
  for (const auto& [key, count] : requests.calls) {
    w.sample("requests_total", double(count),
             fmt::format("rpc=\"{}\",code=\"{}\"", key.first, status_code_name(key.second)));
  }
  w.family("request_duration_seconds", "histogram", "Time to serve a call, by RPC.");
  for (const auto& [rpc, h] : requests.latency) {
    for (size_t i = 0; i < LatencyHistogram::kBounds.size(); ++i) {
      w.sample("request_duration_seconds_bucket", double(h.buckets[i]),
               fmt::format("rpc=\"{}\",le=\"{}\"", rpc, LatencyHistogram::kBounds[i]));
    }
    w.sample("request_duration_seconds_bucket", double(h.count),
             fmt::format("rpc=\"{}\",le=\"+Inf\"", rpc));
    w.sample("request_duration_seconds_sum", h.sum, fmt::format("rpc=\"{}\"", rpc));
    w.sample("request_duration_seconds_count", double(h.count), fmt::format("rpc=\"{}\"", rpc));
  }

  const v1::RequestStatus& r = status.requests();
  w.family("requests_in_flight", "gauge", "Gathers and tiles running.");
  w.sample("requests_in_flight", r.in_flight());
  w.family("requests_queued", "gauge", "Gathers and tiles waiting for a worker slot.");
  w.sample("requests_queued", r.queued());
  w.family("requests_rejected_total", "counter", "Calls refused with RESOURCE_EXHAUSTED.");
  w.sample("requests_rejected_total", double(r.rejected()));

  const v1::CacheStatus& c = status.cache();
  w.family("cache_hits_total", "counter", "Page cache hits.");
  w.sample("cache_hits_total", double(c.hits()));
  w.family("cache_misses_total", "counter", "Page cache misses (pages loaded).");
  w.sample("cache_misses_total", double(c.misses()));
  w.family("cache_evictions_total", "counter", "Pages evicted to stay within the budget.");
  w.sample("cache_evictions_total", double(c.evictions()));
  w.family("cache_read_bytes_total", "counter", "Bytes read from page files.");
  w.sample("cache_read_bytes_total", double(c.bytes_read()));
  w.family("cache_bytes", "gauge", "Bytes of pages held by the cache.");
  w.sample("cache_bytes", double(c.bytes_held()));
  w.family("cache_pinned_bytes", "gauge", "Bytes of pages evicted while gathers pin them (beyond the budget).");
  w.sample("cache_pinned_bytes", double(c.bytes_pinned()));
  w.family("cache_budget_bytes", "gauge", "Byte budget of the page cache.");
  w.sample("cache_budget_bytes", double(c.budget_bytes()));
  w.family("resident_memory_bytes", "gauge", "Resident set size of pbgid.");
  w.sample("resident_memory_bytes", double(status.rss_bytes()));
  if (status.has_memory()) {
    const v1::MemoryStatus& m = status.memory();
    w.family("memory_budget_bytes", "gauge", "The daemon's memory budget (--memory-budget).");
    w.sample("memory_budget_bytes", double(m.budget_bytes()));
    w.family("memory_request_reserve_bytes", "gauge", "The budget's share kept for requests in flight.");
    w.sample("memory_request_reserve_bytes", double(m.request_reserve_bytes()));
    w.family("memory_page_cache_floor_bytes", "gauge", "The page cache is never shrunk below it.");
    w.sample("memory_page_cache_floor_bytes", double(m.page_cache_floor_bytes()));
    w.family("memory_charged_bytes", "gauge",
             "Bytes charged to the budget: open scenes, scenes being read, page-set builds.");
    w.sample("memory_charged_bytes", double(m.scenes_bytes()), "kind=\"scenes\"");
    w.sample("memory_charged_bytes", double(m.reading_bytes()), "kind=\"reading\"");
    w.sample("memory_charged_bytes", double(m.builds_bytes()), "kind=\"builds\"");
    w.family("memory_refusals_total", "counter", "Charges refused with RESOURCE_EXHAUSTED (scenes that did not fit).");
    w.sample("memory_refusals_total", double(m.refusals()));
  }

  w.family("scenes_open", "gauge", "Scenes open.");
  w.sample("scenes_open", status.scenes_size());
  w.family("scene_memory_bytes", "gauge", "Estimated memory of an open scene outside the cache.");
  for (const v1::SceneStatus& s : status.scenes()) {
    w.sample("scene_memory_bytes", double(s.memory_bytes()),
             fmt::format("scene_id=\"{}\"", label(s.info().scene_id())));
  }
  w.family("scene_build_progress", "gauge", "Progress of the current stage of opens in flight.");
  for (const v1::OpenStatus& o : status.opening()) {
    w.sample("scene_build_progress", o.fraction(),
             fmt::format("scene_path=\"{}\",stage=\"{}\"", label(o.scene_path()),
                         label(o.stage())));
  }
  w.family("uptime_seconds", "gauge", "Seconds since the daemon started.");
  w.sample("uptime_seconds", status.uptime_seconds());
  return w.take();
}

}  // namespace pbgi::service
