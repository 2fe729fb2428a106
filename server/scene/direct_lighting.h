// Direct lighting at a diffuse shading point from all lights of the scene,
// with stratified light samples and Embree shadow rays. Shared by surfel
// shading and the tile renderer so they agree exactly.
#pragma once

#include "server/scene/ray_scene.h"

#include <cstdint>
#include <vector>

namespace pbgi {

// Irradiance at p with unit normal n (only the hemisphere around n), using
// `samples` stratified samples per area light; `seed` decorrelates points.
C3f direct_irradiance(const RayScene& rays, const V3f& p, const V3f& n, uint32_t samples,
                      uint64_t seed);

// The same light samples one by one, for lobes that are not Lambertian (a
// glossy surfel's specular lobe): the direction towards the light and the
// sample's share of the irradiance (they sum to direct_irradiance()).
// Shadowed samples are left out. `out` is replaced.
struct IncidentSample {
  V3f direction;
  C3f irradiance;
};
void incident_light(const RayScene& rays, const V3f& p, const V3f& n, uint32_t samples, uint64_t seed,
                    std::vector<IncidentSample>& out);

}  // namespace pbgi
