// Fog as the gather sees it: volume points baked from a scene's fog grids
// (server/volumes/fog_points.h), one per cubic block of the grid at the
// level of detail the surfel spacing needs, each with its extinction and
// the radiance it in-scatters from the direct lights. The gather adds them
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
// Thread-safety: VolumePoints is immutable once built and shared by every
// Gatherer; add_volume_fragments writes only the caller's microbuffer.
#pragma once

#include "server/gather/microbuffer.h"

#include <Imath/ImathBox.h>
#include <Imath/ImathColor.h>
#include <Imath/ImathVec.h>

#include <cstdint>
#include <unordered_map>
#include <vector>

namespace pbgi {

struct VolumePoint {
  Imath::V3f position;          // block centre, scene world
  float sigma_t = 0.f;          // extinction per world unit
  Imath::C3f radiance{0, 0, 0};  // in-scattered radiance (single scattering, isotropic phase)
};

// Points on a regular lattice of cubic blocks of edge `block_size`.
class VolumePoints {
 public:
  VolumePoints() = default;
  // `origin`: the corner of block (0, 0, 0); points must lie at block centres.
  VolumePoints(float block_size, const Imath::V3f& origin, std::vector<VolumePoint> points);

  bool empty() const { return points_.empty(); }
  float block_size() const { return block_; }
  const std::vector<VolumePoint>& points() const { return points_; }
  std::vector<VolumePoint>& mutable_points() { return points_; }  // lighting, before sharing
  const Imath::Box3f& bounds() const { return bounds_; }
  // The point of the block holding p, or null.
  const VolumePoint* at(const Imath::V3f& p) const;
  size_t memory_bytes() const;

 private:
  static uint64_t key(int64_t x, int64_t y, int64_t z);
  float block_ = 0.f, inv_block_ = 0.f;
  Imath::V3f origin_{0, 0, 0};
  Imath::Box3f bounds_;
  std::vector<VolumePoint> points_;
  std::unordered_map<uint64_t, uint32_t> index_;
};

namespace gather {

// Narrows [t0, t1] to the part of p + t d inside `box` (slab test); false
// if none is left. Shared with server/volumes/fog_field.cpp.
bool clip_to_box(const Imath::Box3f& box, const Imath::V3f& p, const Imath::V3f& d, float& t0, float& t1);

// Adds the fog fragments of the receiver at p to `buffer` (begun for its
// normal), out to `max_distance` (<= 0: the whole fog). Returns the number
// of fragments added.
uint64_t add_volume_fragments(const VolumePoints& fog, const Imath::V3f& p, Microbuffer& buffer,
                              float max_distance = 0.f);

}  // namespace gather
}  // namespace pbgi
