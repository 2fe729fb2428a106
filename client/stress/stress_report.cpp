#include "client/stress/stress_report.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace pbgi::stress {
namespace {

constexpr double kMiB = 1024.0 * 1024.0;

std::string quote(const std::string& s) {
  std::string out = "\"";
  for (const char ch : s) {
    const auto c = static_cast<unsigned char>(ch);
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\t': out += "\\t"; break;
      default:
        if (c < 0x20) {
          out += fmt::format("\\u{:04x}", c);
        } else {
          out += ch;
        }
    }
  }
  return out + "\"";
}

// JSON has no inf/nan.
std::string number(double v) { return std::isfinite(v) ? fmt::format("{:.6g}", v) : "null"; }

}  // namespace

RssSummary summarize_rss(const std::vector<RssSample>& samples, uint64_t limit_bytes,
                         const std::string& csv) {
  RssSummary s;
  s.samples = samples.size();
  s.limit_bytes = limit_bytes;
  s.csv = csv;
  if (samples.empty()) return s;
  s.start_bytes = samples.front().rss_bytes;
  s.end_bytes = samples.back().rss_bytes;
  for (const RssSample& r : samples) s.peak_bytes = std::max(s.peak_bytes, r.rss_bytes);
  s.growth_bytes = rss_growth_bytes(samples);
  return s;
}

std::string format_stress_text(const StressResult& r, const std::optional<RssSummary>& rss) {
  std::string out = fmt::format(
      "pbgi stress: {} clients for {:.1f} s on {} server(s), scene {}, camera {}\n", r.clients,
      r.seconds, r.requests_per_server.size(), r.scene_ids.empty() ? "-" : r.scene_ids.front(),
      r.camera);
  out += fmt::format("requests    {} ({} ok, {} errors)  {:.1f} tiles/s  {:.1f} kpixel/s\n",
                     r.requests, r.ok, r.errors(), r.throughput(),
                     r.seconds > 0 ? r.pixels / r.seconds / 1e3 : 0.0);
  out += fmt::format("latency ms  p50 {:.1f}  p95 {:.1f}  p99 {:.1f}  max {:.1f}  mean {:.1f}\n",
                     r.latency.p50_ms, r.latency.p95_ms, r.latency.p99_ms, r.latency.max_ms,
                     r.latency.mean_ms);
  if (r.requests_per_server.size() > 1) {
    out += fmt::format("per server  {}\n", fmt::join(r.requests_per_server, " / "));
  }
  if (r.errors_by_code.empty()) {
    out += "errors      none\n";
  } else {
    out += "errors     ";
    for (const auto& [code, n] : r.errors_by_code) out += fmt::format(" {} x{}", code, n);
    out += "\n";
    for (const std::string& s : r.error_samples) out += "  " + s + "\n";
  }
  if (rss) {
    out += fmt::format(
        "daemon RSS  start {:.1f} MiB  peak {:.1f} MiB  end {:.1f} MiB  growth {:+.1f} MiB "
        "({} samples{}{})\n",
        rss->start_bytes / kMiB, rss->peak_bytes / kMiB, rss->end_bytes / kMiB,
        rss->growth_bytes / kMiB, rss->samples,
        rss->limit_bytes ? fmt::format(", limit {:.0f} MiB{}", rss->limit_bytes / kMiB,
                                       rss->within_limit() ? "" : " EXCEEDED")
                         : std::string(),
        rss->csv.empty() ? std::string() : ", curve in " + rss->csv);
  }
  out += r.passed() && (!rss || rss->within_limit()) ? "PASS\n" : "FAIL\n";
  return out;
}

std::string format_stress_json(const StressResult& r, const std::optional<RssSummary>& rss) {
  std::vector<std::string> errors, samples, ids;
  for (const auto& [code, n] : r.errors_by_code) errors.push_back(fmt::format("{}: {}", quote(code), n));
  for (const std::string& s : r.error_samples) samples.push_back(quote(s));
  for (const std::string& s : r.scene_ids) ids.push_back(quote(s));
  std::string out = "{\n";
  out += fmt::format("  \"passed\": {},\n", r.passed() && (!rss || rss->within_limit()));
  out += fmt::format("  \"scene_ids\": [{}],\n  \"camera\": {},\n", fmt::join(ids, ", "),
                     quote(r.camera));
  out += fmt::format("  \"clients\": {},\n  \"seconds\": {},\n", r.clients, number(r.seconds));
  out += fmt::format("  \"requests\": {},\n  \"ok\": {},\n  \"errors\": {},\n", r.requests, r.ok,
                     r.errors());
  out += fmt::format("  \"errors_by_code\": {{{}}},\n", fmt::join(errors, ", "));
  out += fmt::format("  \"error_samples\": [{}],\n", fmt::join(samples, ", "));
  out += fmt::format("  \"requests_per_server\": [{}],\n", fmt::join(r.requests_per_server, ", "));
  out += fmt::format("  \"tiles_per_second\": {},\n  \"pixels\": {},\n", number(r.throughput()),
                     r.pixels);
  out += fmt::format(
      "  \"latency_ms\": {{\"count\": {}, \"min\": {}, \"mean\": {}, \"p50\": {}, \"p95\": {}, "
      "\"p99\": {}, \"max\": {}}}",
      r.latency.count, number(r.latency.min_ms), number(r.latency.mean_ms),
      number(r.latency.p50_ms), number(r.latency.p95_ms), number(r.latency.p99_ms),
      number(r.latency.max_ms));
  if (rss) {
    out += fmt::format(
        ",\n  \"rss\": {{\"start_bytes\": {}, \"peak_bytes\": {}, \"end_bytes\": {}, "
        "\"growth_bytes\": {}, \"samples\": {}, \"limit_bytes\": {}, \"within_limit\": {}, "
        "\"csv\": {}}}",
        rss->start_bytes, rss->peak_bytes, rss->end_bytes, number(rss->growth_bytes),
        rss->samples, rss->limit_bytes, rss->within_limit(), quote(rss->csv));
  }
  out += "\n}\n";
  return out;
}

}  // namespace pbgi::stress
