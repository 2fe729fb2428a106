// Fog's volume points: a lattice of cubic blocks, each with its extinction
// and the radiance it in-scatters from the direct lights. Baked from a
// scene's fog grids by server/volumes/fog_points.h, composited into
// receivers' microbuffers by server/gather/volume_fragments.h. Held here,
// below both, so that the volumes stage does not depend on the gather.
//
// Thread-safety: VolumePoints is immutable once built and shared by every
// Gatherer.
#pragma once

#include <Imath/ImathBox.h>
#include <Imath/ImathColor.h>
#include <Imath/ImathVec.h>

#include <cstdint>
#include <unordered_map>
#include <vector>

namespace pbgi {

struct VolumePoint {
  Imath::V3f position;           // block centre, scene world
  float sigma_t = 0.f;           // extinction per world unit
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

// Narrows [t0, t1] to the part of p + t d inside `box` (slab test); false
// if none is left. Shared by server/volumes/fog_field.cpp and
// server/gather/volume_fragments.cpp.
bool clip_to_box(const Imath::Box3f& box, const Imath::V3f& p, const Imath::V3f& d, float& t0, float& t1);

}  // namespace pbgi
