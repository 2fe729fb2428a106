// Direct lighting at a diffuse shading point from all lights of the scene,
// with stratified light samples and Embree shadow rays. Shared by surfel
// shading and the tile renderer so they agree exactly.
#pragma once

#include "server/scene/ray_scene.h"

#include <cstdint>

namespace pbgi {

// Irradiance at p with unit normal n (only the hemisphere around n), using
// `samples` stratified samples per area light; `seed` decorrelates points.
C3f direct_irradiance(const RayScene& rays, const V3f& p, const V3f& n, uint32_t samples,
                      uint64_t seed);

}  // namespace pbgi
