// The reference path tracer (server/reference) as a benchmark method: the
// same renderer the reference comes from, at 1, 2, 4, ... samples per pixel
// and a seed distinct from the reference's, so its error against the
// reference is its own Monte Carlo noise.
#pragma once

#include "client/bench/bench_method.h"
#include "server/reference/reference_options.h"

#include <cstdint>
#include <vector>

namespace pbgi::bench {

struct PathSweep {
  // Largest sample count; the sweep is the powers of two up to it (and it).
  uint32_t max_spp = 256;
  // Reflections per path (ReferenceOptions::max_depth); the bench uses the
  // same value for the reference (BenchOptions::max_depth).
  uint32_t max_depth = 2;
  uint64_t seed = 1;

  void validate() const;  // throws InvalidArgument naming the field
};

// 1, 2, 4, ..., max_spp (max_spp appended if it is not a power of two).
std::vector<uint32_t> spp_ladder(uint32_t max_spp);

// ReferenceOptions of a path-traced render of the bench: `spp` samples in
// one pass.
ReferenceOptions path_render_options(uint32_t width, uint32_t height, uint32_t spp,
                                     uint32_t max_depth, uint64_t seed);

MethodPlan path_plan(const PathSweep& sweep);

}  // namespace pbgi::bench
