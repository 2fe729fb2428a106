// The scene's emissive triangles as a light for next-event estimation in the
// reference path tracer: a triangle is chosen with probability proportional
// to its area times its material's emission (power-proportional; a textured
// emission counts by its scale + bias), then a point uniformly on it. The
// density of a point per unit area is then P(triangle) / area(triangle),
// known for any triangle a BSDF-sampled ray hits, so the two strategies can
// be combined by multiple importance sampling.
//
// Thread-safety: immutable after construction.
#pragma once

#include "server/scene/ray_scene.h"

#include <cstdint>
#include <vector>

namespace pbgi {

struct EmitterSample {
  uint32_t triangle = ~0u;
  float b1 = 0, b2 = 0;   // barycentrics of vertices 1 and 2
  SurfacePoint point;     // with its rounding-error bound
  V3f normal;             // unit, from the winding
  float pdf_area = 0.f;   // per unit area, of choosing this point
};

class EmissiveTriangles {
 public:
  explicit EmissiveTriangles(const Scene& scene);

  bool empty() const { return triangles_.empty(); }
  size_t size() const { return triangles_.size(); }
  // A point on an emissive triangle from three uniform numbers in [0, 1).
  EmitterSample sample(float u0, float u1, float u2) const;
  // Density per unit area of sample() choosing a point of `triangle`
  // (0 for a triangle that does not emit).
  float pdf_area(uint32_t triangle) const;

 private:
  const Scene& scene_;
  std::vector<uint32_t> triangles_;  // emissive, non-degenerate
  std::vector<double> cdf_;          // over triangles_, last = 1
  std::vector<float> pdf_area_;      // per entry of triangles_ (ascending ids): a
                                     // dense per-triangle array would grow with instances
};

}  // namespace pbgi
