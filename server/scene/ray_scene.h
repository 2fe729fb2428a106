// Embree acceleration structure over a Scene's triangles: closest hits for
// camera and path rays, occlusion for shadow rays. Thread-safe after build.
#pragma once

#include "server/scene/scene.h"

#include <limits>
#include <memory>

namespace pbgi {

struct Hit {
  float t = std::numeric_limits<float>::infinity();
  uint32_t triangle = ~0u;
  float u = 0, v = 0;             // barycentrics of vertices 1 and 2
  V3f geometric_normal;           // unit, from the winding (v1-v0)x(v2-v0)
  bool valid() const { return triangle != ~0u; }
};

class RayScene {
 public:
  explicit RayScene(const Scene& scene);   // builds the BVH; throws pbgi::Error
  ~RayScene();
  RayScene(const RayScene&) = delete;
  RayScene& operator=(const RayScene&) = delete;

  Hit intersect(const V3f& origin, const V3f& dir, float tmin = 0.f,
                float tmax = std::numeric_limits<float>::infinity()) const;
  bool occluded(const V3f& origin, const V3f& dir, float tmin, float tmax) const;

  // Shading normal at a hit (interpolated if the mesh has normals), unit.
  V3f shading_normal(const Hit& hit) const;
  const Scene& scene() const { return scene_; }

  // Offset for the origins of secondary rays leaving a surface (along its
  // normal), scaled to the scene's size so it clears float error at any
  // scale: 1e-5 of the bounds' diagonal plus a few ulps of the largest
  // coordinate.
  float ray_epsilon() const;

 private:
  struct Impl;
  const Scene& scene_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace pbgi
