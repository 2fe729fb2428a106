// How fog/density grids (Scene::volumes of VolumeKind::Fog) take part in
// light transport: extinction for shadow rays and the gather, and single
// scattering of the scene's direct lights by baked volume points.
#pragma once

#include "common/options/option_table.h"

#include <Imath/ImathColor.h>

#include <cstdint>

namespace pbgi {

struct FogOptions {
  // sigma_t = density * extinction_per_density, per world unit: a grid
  // value of 1 with the default extinguishes 1 - 1/e of the light over one
  // world unit. Grids are authored in arbitrary density units, so this is
  // the one knob that turns them into optical depth.
  float extinction_per_density = 1.f;
  // Single-scattering albedo sigma_s / sigma_t (isotropic phase function).
  // 0 = purely absorbing fog.
  Imath::C3f albedo{0.8f, 0.8f, 0.8f};
  // Ray-marching step along shadow rays, in voxels of the grid's leaf level.
  float step_voxels = 0.5f;
  // Light samples per area light for a volume point's in-scattering.
  uint32_t light_samples = 4;
  // Volume points are baked at the coarsest level whose block edge is no
  // longer than the surfel spacing (fog_points.h); this caps the block
  // edge in voxels (8 = a leaf node, 128 = an internal node of the default
  // 5-4-3 tree).
  uint32_t max_block_voxels = 128;

  void validate() const;  // throws InvalidArgument naming the field
};

// FogOptions' options (common/options/option_table.h says how to add one):
// [fog] in the config, pbgi.v1.FogOptions (BuildOptions.fog), `pbgi`
// flags. Fog is not in the page set (server/engine/scene_fog.h): no
// build-key membership.
inline constexpr auto kFogOptionTable = options::table(
    options::field<&FogOptions::extinction_per_density>(
        "extinction_per_density",
        {1,
         {"--fog-extinction",
          "fog grids: extinction per unit density and world unit (sigma_t = density x this) [1]",
          options::positive()}}),
    // Grey: one value for r, g and b.
    options::custom<FogOptions, float>(
        "albedo", [](const FogOptions& f) { return f.albedo.x; },
        [](FogOptions& f, const float& grey) { f.albedo = Imath::C3f(grey); },
        {2, {"--fog-albedo", "fog grids: grey single-scattering albedo, 0 = absorbing [0.8]", options::range(0, 1)}}),
    options::field<&FogOptions::step_voxels>("step_voxels", {3}),
    options::field<&FogOptions::light_samples>("light_samples", {4}),
    options::field<&FogOptions::max_block_voxels>("max_block_voxels", {5}));

}  // namespace pbgi
