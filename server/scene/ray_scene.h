// Embree acceleration structure over a Scene's triangles (instances as
// Embree instances of one BVH per prototype): closest hits for
// camera and path rays, occlusion for shadow rays. Every query passes
// through surfaces where their material's opacity makes them absent
// (cutouts; fractional opacity per ray, server/scene/surface_opacity.h).
// Thread-safe after build.
#pragma once

#include "server/scene/participating_medium.h"
#include "server/scene/scene.h"

#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <utility>

namespace pbgi {

struct Hit {
  float t = std::numeric_limits<float>::infinity();
  uint32_t triangle = ~0u;        // a Scene::triangle() id (instances included)
  float u = 0, v = 0;             // barycentrics of vertices 1 and 2
  V3f geometric_normal;           // unit, from the winding (v1-v0)x(v2-v0)
  bool valid() const { return triangle != ~0u; }
};

// A point computed in float on a surface, with a per-component bound on its
// rounding error: the exact point of the surface it stands for lies in the
// box p +- error (pbrt-v4's Point3fi). Rays leaving the point start outside
// that box (RayScene::offset_ray_origin), so they cannot re-hit the surface
// they leave, whatever the magnitude of the coordinates.
struct SurfacePoint {
  V3f p;
  V3f error{0.f, 0.f, 0.f};
};

// Accepts or rejects a candidate hit of RayScene::intersect().
using HitFilter = std::function<bool(const Hit&)>;

// The configuration string of the Embree devices RayScenes create from now
// on (rtcNewDevice's config, e.g. "isa=sse4.2"); "" (the default) lets
// Embree pick the widest ISA of the CPU. Embree's traversal order, and so
// which of two coincident triangles a ray meets first, may differ between
// ISAs: tests run the ray queries under two of them (tests/support), and
// callers must not depend on that order (intersect() with a filter).
// Not thread-safe against concurrent RayScene construction.
void set_embree_device_config(std::string config);
const std::string& embree_device_config();

class RayScene {
 public:
  explicit RayScene(const Scene& scene);   // builds the BVH; throws pbgi::Error
  ~RayScene();
  RayScene(const RayScene&) = delete;
  RayScene& operator=(const RayScene&) = delete;

  Hit intersect(const V3f& origin, const V3f& dir, float tmin = 0.f,
                float tmax = std::numeric_limits<float>::infinity()) const;
  // The closest hit in [tmin, tmax] that `accept` accepts: the others are
  // passed through inside the traversal (an Embree context filter), so a
  // rejected triangle cannot hide an accepted one at the same distance, as
  // stepping tmin past a rejected hit would. `accept` may be called from
  // the calling thread only, in any order of candidates.
  Hit intersect(const V3f& origin, const V3f& dir, float tmin, float tmax,
                const HitFilter& accept) const;
  bool occluded(const V3f& origin, const V3f& dir, float tmin, float tmax) const;

  // Fog and other media (participating_medium.h): set once after the
  // build, before any query from other threads; null = none. The medium
  // must outlive the RayScene's use of it.
  void set_medium(std::shared_ptr<const ParticipatingMedium> medium) { medium_ = std::move(medium); }
  const ParticipatingMedium* medium() const { return medium_ && !medium_->empty() ? medium_.get() : nullptr; }
  // Transmittance of the medium along the segment (1 without a medium).
  float transmittance(const V3f& origin, const V3f& dir, float tmin, float tmax) const {
    const ParticipatingMedium* m = medium();
    return m ? m->transmittance(origin, dir, tmin, tmax) : 1.f;
  }

  // Shading normal at a hit (interpolated if the mesh has normals), unit.
  V3f shading_normal(const Hit& hit) const;
  const Scene& scene() const { return scene_; }

  // The hit point p0 + u (p1 - p0) + v (p2 - p0) of a valid hit, with the
  // bound on its rounding error (relative to the hit point's own
  // coordinates, not to the scene's: tight far from the origin too).
  SurfacePoint hit_point(const Hit& hit) const;
  // The point p0 + b1 (p1 - p0) + b2 (p2 - p0) of a triangle with that
  // bound (hit_point() for a hit; samplers of points on triangles).
  static SurfacePoint triangle_point(const V3f& p0, const V3f& p1, const V3f& p2, float b1,
                                     float b2);

  // Error bound for a point p computed on one of the scene's triangles by
  // interpolating its vertices when the triangle's own bound is not at hand
  // (surfel positions, receivers): gamma(8) (|p| + extent) per component,
  // where extent bounds any one triangle's size (the largest side of the
  // scene's bulk or of an outlying triangle, server/scene/scene_bulk.h), so
  // the bound covers |b0 p0| + |b1 p1| + |b2 p2| for any point of any
  // triangle of the scene.
  V3f point_error(const V3f& p) const;

  // Origin for a ray leaving the surface point (p, error) with geometric
  // normal n in direction w (pbrt-v4's OffsetRayOrigin): p moved along n,
  // to w's side, by the error box's extent along n, then rounded away from
  // the surface. The offset is a few ulps of p's own coordinates and of its
  // triangle's size (for a hit point on a unit-size triangle: ~1e-6 near
  // the origin, ~0.02 units at 1e5), where a global epsilon must cover the
  // scene's farthest point everywhere (the old one: 0.38 units at 1e5).
  static V3f offset_ray_origin(const SurfacePoint& p, const V3f& n, const V3f& w);
  V3f offset_ray_origin(const V3f& p, const V3f& n, const V3f& w) const {
    return offset_ray_origin(SurfacePoint{p, point_error(p)}, n, w);
  }

  // The largest offset offset_ray_origin() applies to points of this scene
  // (its farthest corner's point_error() along the worst axis): a scalar
  // for callers that offset points by hand. Prefer offset_ray_origin(),
  // which is relative to the point.
  float ray_epsilon() const;

  // Bytes Embree holds for this scene now (its copies of vertices and
  // indices, the BVHs), and the most it held, build scratch included.
  // Thread-safe.
  uint64_t memory_bytes() const;
  uint64_t peak_memory_bytes() const;

 private:
  struct Impl;
  struct FilterContext;  // an Embree intersect context carrying a HitFilter
  // A Hit of this scene from Embree's ids (instance: RTC_INVALID_GEOMETRY_ID for the world soup).
  Hit make_hit(unsigned instance, unsigned primitive, float u, float v, float t, const V3f& dir) const;
  Hit trace(const V3f& origin, const V3f& dir, float tmin, float tmax, const HitFilter* accept) const;

  const Scene& scene_;
  std::unique_ptr<Impl> impl_;
  std::shared_ptr<const ParticipatingMedium> medium_;
};

}  // namespace pbgi
