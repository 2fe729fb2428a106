// Fog as the gather sees it: volume points (server/scene/volume_points.h)
// baked from a scene's fog grids (server/volumes/fog_points.h), one per
// cubic block of the grid at the level of detail the surfel spacing needs,
// each with its extinction and the radiance it in-scatters from the direct
// lights. The gather adds them
// to a receiver's microbuffer as an attenuating, emitting layer:
//
//   for every pixel of the receiver's hemisphere, the pixel's ray is
//   marched through the blocks (steps of half a block) and cut into depth
//   slices whose far/near ratio is 1 + 2 depth_band, so no two slices fall
//   into one surface cluster (microbuffer.h): each slice becomes a coverage
//   fragment of alpha = 1 - exp(-tau_slice), weight alpha * the pixel's
//   cosine weight and radiance = the slice's in-scattered radiance per unit
//   alpha. The resolve then composites slices and surfaces front to back:
//   a surface at depth z is attenuated by exp(-sum tau) of the slices in
//   front of it, and the fog adds its own light and AO occlusion.
//
// Cost: pixels in the hemisphere x (fog path length / half a block) hash
// look-ups per receiver -- why the blocks are as coarse as the spacing
// allows. Approximation: a slice that shares a depth band with a surface
// joins that surface's cluster (alphas add).
//
// Thread-safety: add_volume_fragments reads the shared VolumePoints and
// writes only the caller's microbuffer.
#pragma once

#include "server/gather/microbuffer.h"
#include "server/scene/volume_points.h"

#include <Imath/ImathVec.h>

#include <cstdint>

namespace pbgi::gather {

// Adds the fog fragments of the receiver at p to `buffer` (begun for its
// normal), out to `max_distance` (<= 0: the whole fog). Returns the number
// of fragments added.
uint64_t add_volume_fragments(const VolumePoints& fog, const Imath::V3f& p, Microbuffer& buffer,
                              float max_distance = 0.f);

}  // namespace pbgi::gather
