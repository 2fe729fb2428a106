#include "server/gather/ray_depth_caps.h"

#include <algorithm>
#include <limits>

namespace pbgi::gather {

void RayDepthCaps::compute(const RayScene* rays, const Imath::V3f& p, const Imath::V3f& n) {
  active_ = rays != nullptr;
  if (!active_) return;
  const uint32_t count = layout_.pixel_count(), res = layout_.resolution();
  hit_.resize(count);
  cap_.resize(count);
  constexpr float kInf = std::numeric_limits<float>::infinity();
  // 1. One ray per pixel whose center lies above the horizon, from just
  //    off the receiver's surface (its rounding error bound, on the
  //    normal's side). Pixels below the horizon show nothing; those
  //    straddling it take their neighbours' caps.
  const Imath::V3f origin = rays->offset_ray_origin(p, n, n);
  for (uint32_t k = 0; k < count; ++k) {
    const Imath::V3f d = layout_.direction(k);
    if (!(d.dot(n) > 0.f)) {
      hit_[k] = -1.f;
      continue;
    }
    hit_[k] = rays->intersect(origin, d).t;  // +infinity when it escapes
    ++rays_cast_;
  }
  // 2. Caps: the farthest hit over the pixel and its 8 neighbours on the
  //    same face, with the margin.
  for (int face = 0; face < CubeLayout::kFaces; ++face) {
    for (uint32_t j = 0; j < res; ++j) {
      for (uint32_t i = 0; i < res; ++i) {
        float far = -1.f;
        const uint32_t r = kNeighbourhood;
        for (uint32_t jj = j > r ? j - r : 0; jj <= std::min(j + r, res - 1); ++jj)
          for (uint32_t ii = i > r ? i - r : 0; ii <= std::min(i + r, res - 1); ++ii)
            far = std::max(far, hit_[layout_.index(face, ii, jj)]);
        cap_[layout_.index(face, i, j)] = far < 0.f ? kInf : far * (1.f + kCapMargin);
      }
    }
  }
}

}  // namespace pbgi::gather
