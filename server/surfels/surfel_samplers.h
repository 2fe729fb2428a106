// The samplers behind sample_surfels() and generate_surfels(). Each hands
// unshaded surfels (radiance = emission) to `sink` in generation order, in
// chunks of a bounded size, without holding every surfel: the generation
// of a page set streams (surfels.h).
//
// Thread-safety: reentrant; the scene is only read.
#pragma once

#include "server/surfels/surfels.h"

#include <functional>
#include <span>

namespace pbgi {

using SurfelChunkSink = std::function<void(std::span<const Surfel>)>;

// Uniform density (surfel_sampling.cpp).
void sample_uniform(const Scene& scene, const SurfelOptions& options, const SurfelChunkSink& sink,
                    const ProgressFn& progress);

// Poisson disk, absolute or camera-adaptive spacing (poisson_sampling.cpp).
void sample_poisson(const Scene& scene, const SurfelOptions& options, const SurfelChunkSink& sink,
                    const ProgressFn& progress);

// Total area of the valid triangles, double-sided meshes counted twice (one
// surfel per face), and the number of triangles skipped as degenerate.
struct SceneArea {
  double total = 0;
  uint64_t skipped = 0;
};
SceneArea scene_area(const Scene& scene);

// The absolute spacing of `options` for `scene`: options.spacing, or the
// one giving about target_surfels over the area. Throws InvalidArgument if
// it would produce more than 2^31 surfels.
float absolute_spacing(const Scene& scene, const SurfelOptions& options, double total_area);

}  // namespace pbgi
