#include "server/scene/volume_points.h"

#include <algorithm>
#include <cmath>

namespace pbgi {

VolumePoints::VolumePoints(float block_size, const Imath::V3f& origin, std::vector<VolumePoint> points)
    : block_(block_size), inv_block_(1.f / block_size), origin_(origin), points_(std::move(points)) {
  index_.reserve(points_.size());
  for (uint32_t i = 0; i < points_.size(); ++i) {
    const Imath::V3f c = (points_[i].position - origin_) * inv_block_;
    index_[key(int64_t(std::floor(c.x)), int64_t(std::floor(c.y)), int64_t(std::floor(c.z)))] = i;
    const Imath::V3f h(0.5f * block_);
    bounds_.extendBy(points_[i].position - h);
    bounds_.extendBy(points_[i].position + h);
  }
}

uint64_t VolumePoints::key(int64_t x, int64_t y, int64_t z) {
  // 21 bits per axis (two's complement, wrapped): 2M blocks per side.
  constexpr uint64_t m = (1u << 21) - 1;
  return (uint64_t(x) & m) | (uint64_t(y) & m) << 21 | (uint64_t(z) & m) << 42;
}

const VolumePoint* VolumePoints::at(const Imath::V3f& p) const {
  if (!bounds_.intersects(p)) return nullptr;
  const Imath::V3f c = (p - origin_) * inv_block_;
  const auto it = index_.find(key(int64_t(std::floor(c.x)), int64_t(std::floor(c.y)), int64_t(std::floor(c.z))));
  return it == index_.end() ? nullptr : &points_[it->second];
}

size_t VolumePoints::memory_bytes() const {
  return points_.capacity() * sizeof(VolumePoint) + index_.size() * (sizeof(uint64_t) + sizeof(uint32_t) + 16);
}

bool clip_to_box(const Imath::Box3f& box, const Imath::V3f& p, const Imath::V3f& d, float& t0, float& t1) {
  for (int a = 0; a < 3; ++a) {
    if (d[a] == 0.f) {
      if (p[a] < box.min[a] || p[a] > box.max[a]) return false;
      continue;
    }
    float n = (box.min[a] - p[a]) / d[a], f = (box.max[a] - p[a]) / d[a];
    if (n > f) std::swap(n, f);
    t0 = std::max(t0, n);
    t1 = std::min(t1, f);
  }
  return t0 < t1;
}

}  // namespace pbgi
