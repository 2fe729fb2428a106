// Surfel generation: uniform-density sampling of the scene's triangles, then
// direct lighting of every surfel with Embree shadow rays.
#pragma once

#include "server/scene/ray_scene.h"
#include "server/surfels/surfel_options.h"
#include "storage/tree/surfel.h"

#include <functional>
#include <vector>

namespace pbgi {

using ProgressFn = std::function<void(const char* stage, float fraction)>;

// Samples surfels (position, normal, radius, albedo, emission) over all
// triangles; radiance is left as emission.
std::vector<Surfel> sample_surfels(const Scene& scene, const SurfelOptions& options,
                                   const ProgressFn& progress = {});

// Adds reflected direct light to each surfel's radiance: albedo/pi * E_direct.
void shade_direct(const RayScene& rays, const SurfelOptions& options,
                  std::vector<Surfel>& surfels, const ProgressFn& progress = {});

}  // namespace pbgi
