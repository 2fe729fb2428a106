// PBGI and factorized PBGI as benchmark methods: one build (surfels + page
// set, through open_scene_model) per surfel budget and payload codec, then
// one render per gather setting (method x microbuffer resolution x cut
// threshold) with render_tile over the whole image.
#pragma once

#include "client/bench/bench_method.h"
#include "client/bench/payload_spec.h"
#include "server/gather/gather_options.h"
#include "server/gather/surfel_bounce.h"
#include "server/render/tile_renderer.h"

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
  // Gather methods: each renders every setting above from the same page
  // sets (method "pbgi" or "fpbgi" in bench.csv, one curve each).
  std::vector<GatherMethod> methods{GatherMethod::kPbgi, GatherMethod::kFpbgi};
  GatherMethod default_method = GatherMethod::kPbgi;
  // FPBGI's clusters per 1024 receivers (k) and far/near split (0 = auto),
  // GatherOptions' defaults.
  uint32_t fpbgi_clusters = GatherOptions{}.clusters;
  float fpbgi_epsilon = GatherOptions{}.epsilon;
  // Glossy receivers' finest lobe microbuffer (GatherOptions'; at or below
  // the microbuffer resolution: the fixed buffer), for every render.
  uint32_t glossy_max_resolution = GatherOptions{}.glossy_max_resolution;
  // And how much of its refinement follows incoming radiance (GatherOptions').
  float glossy_radiance_weight = GatherOptions{}.glossy_radiance_weight;
  // Ray-traced depth caps of the microbuffer (GatherOptions'), for every render.
  bool ray_depth_caps = GatherOptions{}.ray_depth_caps;
  // Payload codecs. The first gets the full sweep above (the default
  // configuration is one of its); every other one is one more page set at
  // default_target_surfels, rendered by each method at each microbuffer
  // resolution at default_max_solid_angle: a curve per method and codec.
  std::vector<PayloadSpec> payloads{
      PayloadSpec{},
      PayloadSpec{tree::PayloadCodecOption::kQuantizedSh, 1024}};
  // RenderOptions of every PBGI render (camera rays per pixel, shadow rays
  // per pixel sample and light) and SurfelOptions::light_samples of builds.
  uint32_t pixel_samples = RenderOptions{}.pixel_samples;
  // Camera rays of a pixel on a light's silhouette (RenderOptions::edge_samples).
  uint32_t edge_samples = RenderOptions{}.edge_samples;
  // Extra renders of the default configuration with more camera rays per
  // pixel. The beauty's error against the pixel-averaged reference is
  // mostly aliasing of edges and of lights seen by the camera; these show
  // what more antialiasing costs.
  std::vector<uint32_t> extra_pixel_samples{16};
  uint32_t light_samples = 16;
  uint32_t surfel_light_samples = 16;
  // Interpolation settings every gather setting is rendered with
  // (server/render/gather_lattice.h); the first is the default's. More than
  // one: each gets its own curve (names end in /interp-off or /tol<t>).
  std::vector<InterpolationOptions> interpolations{InterpolationOptions{}};
  uint64_t seed = 1;
  // Light bounces every build puts into the surfels, with their bounce
  // gather and splatting (server/gather/surfel_bounce.h); the default, 1:
  // direct light only. Compare with a path tracer of max_depth bounces + 1.
  BounceOptions bounce;

  // Throws InvalidArgument naming the field (empty lists, repeated methods
  // or payloads, values the gather, surfel or build options reject, defaults
  // not in the lists).
  void validate() const;
};

// Configurations at default_target_surfels, default_max_solid_angle and
// pixel_samples (every method, microbuffer and payload) are marked
// MethodConfig::equal_error_point: the runner matches the path tracer's
// cost to each of their errors.
MethodPlan pbgi_plan(const PbgiSweep& sweep);

// "pbgi" or "fpbgi"; parse_gather_method throws InvalidArgument otherwise.
std::string gather_method_name(GatherMethod method);
GatherMethod parse_gather_method(const std::string& name);

}  // namespace pbgi::bench
