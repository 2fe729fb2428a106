// A surfel's reflectance from its triangle's material: the diffuse albedo
// the shading multiplies with irradiance, and, for a glossy material, the
// GGX lobe whose outgoing radiance the tree stores as wavelet cube maps
// (storage/codecs/glossy_pages.h).
#pragma once

#include "server/scene/scene.h"
#include "server/scene/surface_colors.h"
#include "storage/tree/surfel.h"

#include <cstdint>

namespace pbgi {

// Sets s.albedo and s.emission from `colors` (the material at the surfel),
// and for a material whose specular lobe (server/scene/brdf.h) has a
// roughness below `glossy_roughness`, s.gloss and s.albedo = the lobe
// split's diffuse part (a metal's is black). Rougher specular lobes are
// left Lambertian with the full albedo, as before glossy senders existed.
void set_surfel_material(const Scene& scene, uint32_t triangle, const SurfaceColors& colors,
                         float glossy_roughness, Surfel& s);

}  // namespace pbgi
