// PBGI as a benchmark method: one build (surfels + page set, through
// open_scene_model) per surfel budget, then one render per gather setting
// (microbuffer resolution x cut threshold) with render_tile over the whole
// image.
#pragma once

#include "client/bench/bench_method.h"

#include <cstdint>
#include <vector>

namespace pbgi::bench {

struct PbgiSweep {
  // Surfel budgets (SurfelOptions::target_surfels): one page set each.
  std::vector<uint64_t> target_surfels{50000, 200000};
  // GatherOptions::microbuffer_resolution values.
  std::vector<uint32_t> microbuffer_resolutions{4, 8, 16};
  // GatherOptions::max_solid_angle values, coarse to fine.
  std::vector<float> max_solid_angles{0.3f, 0.1f, 0.03f, 0.01f};
  // The default configuration, whose error the path tracer is matched to:
  // the library defaults (SurfelOptions, GatherOptions). Each must be one of
  // the swept values above.
  uint64_t default_target_surfels = 200000;
  uint32_t default_microbuffer_resolution = 8;
  float default_max_solid_angle = 0.03f;
  // RenderOptions of every PBGI render (camera rays per pixel, shadow rays
  // per pixel sample and light) and SurfelOptions::light_samples of builds.
  uint32_t pixel_samples = 1;
  // Extra renders of the default configuration with more camera rays per
  // pixel (each one gathers). With one ray through the
  // pixel centre, the beauty's error against the pixel-averaged reference
  // is mostly aliasing of edges and of lights seen by the camera; these
  // show what antialiasing costs.
  std::vector<uint32_t> extra_pixel_samples{4};
  uint32_t light_samples = 16;
  uint32_t surfel_light_samples = 16;
  uint64_t seed = 1;

  // Throws InvalidArgument naming the field (empty lists, values the gather
  // or surfel options reject, defaults not in the lists).
  void validate() const;
};

MethodPlan pbgi_plan(const PbgiSweep& sweep);

}  // namespace pbgi::bench
