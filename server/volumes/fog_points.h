// Fog grids -> the volume points (server/scene/volume_points.h) the gather
// composites (server/gather/volume_fragments.h), at the level of detail the
// surfel spacing needs.
//
// Level of detail: a point stands for a cubic block of f^3 voxels, f the
// largest power of two with f * voxel <= spacing (at most
// FogOptions::max_block_voxels): at f = 8 a block is exactly one leaf node
// of OpenVDB's default 5-4-3 tree (its mean over 512 voxels), at 128 one
// internal node. The block's sigma_t is the mean density over its voxels
// (inactive ones count as the background, 0) times extinction_per_density;
// active tiles of the upper tree levels are spread over the blocks they
// cover. So the gather never resolves fog finer than the surfaces it sees.
//
// Lighting (light_fog_points): single scattering of the scene's direct
// lights with an isotropic phase function,
//   S = albedo / (4 pi) * sum over lights E_4pi(light, p) * T(p -> light),
// E_4pi estimated with FogOptions::light_samples stratified samples per area
// light, Embree shadow rays and the fog's own transmittance (fog_field.h).
//
// All fog volumes of a scene share one lattice (the finest block size among
// them, aligned with the first grid; blocks of several grids falling into
// one cell add their sigma_t, a block of a rotated or shifted grid snaps to
// the cell holding its centre), so the gather marches one structure.
#pragma once

#include "server/scene/ray_scene.h"
#include "server/scene/volume_points.h"
#include "server/volumes/fog_field.h"
#include "server/volumes/fog_options.h"

#include <cstdint>
#include <vector>

namespace pbgi {

struct FogPointStats {
  uint32_t block_voxels = 0;  // f of the level used (0: no fog)
  uint64_t points = 0;
  uint64_t active_voxels = 0;  // of the grids baked
};

// Geometry and extinction of the points (radiance left 0). Throws
// InvalidArgument for invalid options or a non-positive spacing.
VolumePoints bake_fog_points(const Scene& scene, float spacing, const FogOptions& options,
                             FogPointStats* stats = nullptr);

// Fills each point's in-scattered radiance (see above). `rays` gives shadow
// rays (its medium, if any, is not used: `fog` is).
void light_fog_points(const RayScene& rays, const FogField& fog, const FogOptions& options, VolumePoints& points);

}  // namespace pbgi
