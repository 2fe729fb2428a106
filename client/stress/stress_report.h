// The outcome of a stress or soak run as text for people and JSON for
// scripts (scripts/soak.sh, CI).
#pragma once

#include "client/stress/rss_sampler.h"
#include "client/stress/stress_runner.h"

#include <optional>
#include <string>

namespace pbgi::stress {

// The daemon's memory over the run (pbgi stress --daemon-pid).
struct RssSummary {
  uint64_t start_bytes = 0, peak_bytes = 0, end_bytes = 0;
  double growth_bytes = 0;      // rss_growth_bytes(): late mean - early mean
  size_t samples = 0;
  uint64_t limit_bytes = 0;     // --max-rss; 0 = none
  std::string csv;              // where the curve was written ("" = nowhere)
  bool within_limit() const { return limit_bytes == 0 || peak_bytes <= limit_bytes; }
};

RssSummary summarize_rss(const std::vector<RssSample>& samples, uint64_t limit_bytes,
                         const std::string& csv);

std::string format_stress_text(const StressResult& result, const std::optional<RssSummary>& rss);
std::string format_stress_json(const StressResult& result, const std::optional<RssSummary>& rss);

}  // namespace pbgi::stress
