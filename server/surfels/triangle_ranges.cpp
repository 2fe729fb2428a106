#include "server/surfels/triangle_ranges.h"

#include <cmath>

namespace pbgi {

float TriangleRange::area(uint32_t j) const {
  const TriangleRef r = triangle(j);
  const V3f p0 = r.position(0), p1 = r.position(1), p2 = r.position(2);
  const float a = 0.5f * (p1 - p0).cross(p2 - p0).length();
  return std::isfinite(a) && a > 0.f ? a : 0.f;
}

V3f TriangleRange::soup_point(uint32_t j, float b1, float b2) const {
  const auto c = triangle(j).corners();
  const std::vector<V3f>& p = soup->positions;
  return (1.f - b1 - b2) * p[c[0]] + b1 * p[c[1]] + b2 * p[c[2]];
}

TriangleRange triangle_range(const Scene& scene, size_t r) {
  if (r == 0) return TriangleRange{&scene.triangles, nullptr, 0};
  const Instance& inst = scene.instances[r - 1];
  return TriangleRange{&scene.prototypes[inst.prototype].triangles, &inst,
                       uint32_t(scene.triangles.triangle_count() + inst.first_triangle)};
}

RangeArea range_area(const TriangleRange& range) {
  RangeArea out;
  const uint32_t n = range.size();
  for (uint32_t j = 0; j < n; ++j) {
    const float a = range.area(j);
    if (a == 0.f) {
      ++out.skipped;
      continue;
    }
    out.total += a * (range.double_sided(j) ? 2.0 : 1.0);
  }
  return out;
}

}  // namespace pbgi
