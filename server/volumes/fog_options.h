// How fog/density grids (Scene::volumes of VolumeKind::Fog) take part in
// light transport: extinction for shadow rays and the gather, and single
// scattering of the scene's direct lights by baked volume points.
#pragma once

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

}  // namespace pbgi
