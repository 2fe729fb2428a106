#include "client/bench/bench_options.h"

#include "common/errors.h"

#include <fmt/format.h>

namespace pbgi::bench {

void BenchOptions::validate() const {
  constexpr uint32_t kMaxSize = 4096;
  if (width == 0 || height == 0 || width > kMaxSize || height > kMaxSize)
    throw InvalidArgument(fmt::format("bench: image size {}x{} outside 1..{}", width, height, kMaxSize));
  if (out_dir.empty()) throw InvalidArgument("bench: out_dir is required");
  if (reference_spp == 0) throw InvalidArgument("bench: reference_spp must be >= 1");
  if (reference_spp < path.max_spp)
    throw InvalidArgument(fmt::format(
        "bench: reference_spp ({}) must be at least the path tracer's max_spp ({}); the reference "
        "should be far more converged than any swept render",
        reference_spp, path.max_spp));
  if (reference_seed == path.seed)
    throw InvalidArgument("bench: reference_seed must differ from the path sweep's seed (the "
                          "sweep would be measured against its own samples)");
  if (page_cache_bytes == 0) throw InvalidArgument("bench: page_cache_bytes must be > 0");
  pbgi.validate();
  path.validate();
}

BenchOptions quick_bench_options() {
  BenchOptions o;
  o.width = 64;
  o.height = 64;
  o.pbgi.target_surfels = {20000};
  o.pbgi.microbuffer_resolutions = {4, 8};
  o.pbgi.max_solid_angles = {0.1f, 0.03f};
  o.pbgi.default_target_surfels = 20000;
  o.path.max_spp = 64;
  o.reference_spp = 1024;
  return o;
}

}  // namespace pbgi::bench
