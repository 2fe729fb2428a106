// Ray-traced depth caps of a receiver's microbuffer (docs/microbuffer.md,
// section 4b; GatherOptions::ray_depth_caps, off by default).
//
// Before a receiver's walk, one ray per microbuffer pixel whose center
// direction lies above the receiver's horizon finds the first surface of
// the scene's geometry there. A pixel's cap is the farthest of those hits
// over the pixels within kNeighbourhood of it on the same face (a splat's
// tent spreads it over its neighbours' directions), times 1 + kCapMargin;
// +infinity where a ray of the neighbourhood escapes or none was cast. The
// rasterizer drops a fragment whose splat's bounding sphere lies wholly
// beyond its pixel's cap: whatever it shows is behind a surface that every
// ray of the neighbourhood met first.
//
// Why: splats of a wall tile it only roughly, so each pixel passes part of
// what lies behind the wall; and the tree's nodes mix the dark floor of a
// closed room with the sunlit ground outside its walls (the Morton tree
// separates surfaces 1 cm apart only ~11 levels down). The surfels cannot
// tell; the geometry can. Figures and cost:
// docs/measurements/2026-11-27-closed-rooms.md.
//
// Thread-safety: none; one per CutWalker. The RayScene is read-only and
// thread-safe. No allocation per receiver once sized.
#pragma once

#include "server/gather/cube_layout.h"
#include "server/scene/ray_scene.h"

#include <Imath/ImathVec.h>

#include <cstdint>
#include <vector>

namespace pbgi::gather {

class RayDepthCaps {
 public:
  // Relative slack of a cap: the hit and the surfels of its surface differ
  // by their rounding and by a splat's own depth.
  static constexpr float kCapMargin = 0.02f;
  // A cap is the farthest hit of the pixels within this many of it on its
  // face (2: a 5 x 5 block).
  static constexpr uint32_t kNeighbourhood = 2;

  explicit RayDepthCaps(const CubeLayout& layout) : layout_(layout) {}

  // Casts the receiver's rays against `rays` (null: no caps) and sets the
  // caps; clear() when the receiver gets none.
  void compute(const RayScene* rays, const Imath::V3f& p, const Imath::V3f& n);
  void clear() { active_ = false; }
  bool active() const { return active_; }

  // The cap of pixel k (+infinity when none). Only while active().
  float cap(uint32_t k) const { return cap_[k]; }
  // Whether a fragment of pixel k whose nearest point lies at depth
  // `near` is hidden by the pixel's cap. Only while active().
  bool hides(uint32_t k, float near) const { return near > cap_[k]; }

  // Rays cast since construction (GatherCounters::depth_rays).
  uint64_t rays_cast() const { return rays_cast_; }

 private:
  const CubeLayout& layout_;
  bool active_ = false;
  uint64_t rays_cast_ = 0;
  std::vector<float> hit_;  // per pixel: the first hit's distance, or < 0 when not cast
  std::vector<float> cap_;  // per pixel
};

}  // namespace pbgi::gather
