// Surfel generation: sampling the scene's triangles (uniform density or
// Poisson disk, absolute or camera-adaptive spacing; SurfelOptions), then
// direct lighting of every surfel with Embree shadow rays.
//
// generate_surfels() streams: surfels are sampled and shaded batch by batch
// and handed to a sink (the page-set builder sorts them to disk), so no
// more than options.batch_surfels are held. sample_surfels() and
// shade_direct() are the same two steps over a vector held in memory, for
// tests and small scenes; both paths give the same surfels in the same
// order.
#pragma once

#include "server/scene/ray_scene.h"
#include "server/surfels/surfel_options.h"
#include "storage/tree/surfel.h"

#include <functional>
#include <span>
#include <vector>

namespace pbgi {

using ProgressFn = std::function<void(const char* stage, float fraction)>;

// Samples surfels (position, normal, radius, albedo, emission) over all
// triangles; radiance is left as emission. Throws InvalidArgument for
// invalid options (or a spacing that would give more than 2^31 surfels),
// SceneError for an invalid scene.
std::vector<Surfel> sample_surfels(const Scene& scene, const SurfelOptions& options,
                                   const ProgressFn& progress = {});

// Adds reflected direct light to each surfel's radiance: albedo/pi * E_direct.
// `first_index` is the generation index of surfels[0]: each surfel's light
// samples are seeded by its index, so shading a batch gives what shading
// the whole sequence would.
void shade_direct(const RayScene& rays, const SurfelOptions& options,
                  std::vector<Surfel>& surfels, const ProgressFn& progress = {});
void shade_direct(const RayScene& rays, const SurfelOptions& options, std::span<Surfel> surfels,
                  uint64_t first_index);

// Receives batches of shaded surfels in generation order.
using SurfelSink = std::function<void(std::span<const Surfel>)>;

struct SurfelGenerationStats {
  uint64_t surfels = 0;
  uint64_t batches = 0;
  double sample_seconds = 0;  // wall time in the sampler
  double shade_seconds = 0;   // wall time shading
  double sink_seconds = 0;    // wall time in the sink
};

// Samples and shades the scene's surfels batch by batch into `sink`. The
// surfels equal sample_surfels() followed by shade_direct(). Progress is
// reported under "sample_surfels" (shading runs between sampled batches).
// Throws what sample_surfels() throws and whatever `sink` throws.
SurfelGenerationStats generate_surfels(const Scene& scene, const RayScene& rays, const SurfelOptions& options,
                                       const SurfelSink& sink, const ProgressFn& progress = {});

}  // namespace pbgi
