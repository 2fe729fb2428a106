// The scene's triangles as ranges that share one soup and one transform:
// the world soup (range 0), then one range per instance, in triangle-id
// order (Scene::triangle). Samplers walk the scene range by range so their
// working memory follows the largest soup (a prototype's triangles), not
// the number of triangles with instances expanded: 10,000 instances of a
// 20k-triangle prototype are 10,000 walks over one 20k-entry plan rather
// than one 200M-entry plan.
//
// Thread-safety: plain values over a const Scene.
#pragma once

#include "server/scene/scene.h"

#include <cstdint>

namespace pbgi {

struct TriangleRange {
  const TriangleSoup* soup = nullptr;
  const Instance* instance = nullptr;  // null: the world soup
  uint32_t first_id = 0;               // scene triangle id of soup triangle 0

  uint32_t size() const { return uint32_t(soup->triangle_count()); }
  // Triangle j of the range, world-space accessors (instances transformed).
  TriangleRef triangle(uint32_t j) const { return TriangleRef{soup, j, instance}; }
  // World-space area of one face of triangle j; 0 for a degenerate or
  // non-finite one. Bit-identical to transforming the vertices and taking
  // half the cross product's length, which is what every sampler used.
  float area(uint32_t j) const;
  bool double_sided(uint32_t j) const { return triangle(j).double_sided(); }
  // Position in the soup's own space (the prototype's, for an instance) of
  // the point with barycentrics (b1, b2) in TriangleRef::corners() order.
  V3f soup_point(uint32_t j, float b1, float b2) const;
};

// 1 + the number of instances.
inline size_t range_count(const Scene& scene) { return 1 + scene.instances.size(); }
// Range r < range_count(scene): 0 the world soup, k + 1 instance k.
TriangleRange triangle_range(const Scene& scene, size_t r);

// Area of a range's valid triangles, double-sided ones counted twice, and
// the degenerate ones skipped; summed in triangle order in double.
struct RangeArea {
  double total = 0;
  uint64_t skipped = 0;
};
RangeArea range_area(const TriangleRange& range);

}  // namespace pbgi
