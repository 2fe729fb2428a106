// Sampling UsdLux lights from a shading point, shared by surfel shading,
// the tile renderer and the reference path tracer so that all of them light
// a scene identically.
#pragma once

#include "server/scene/scene.h"

namespace pbgi {

struct LightSample {
  V3f direction;         // unit, from the shading point toward the light
  float distance = 0.f;  // to the sampled point (infinity for distant and dome lights)
  C3f radiance{0, 0, 0}; // emitted radiance toward the shading point
  float pdf = 0.f;       // solid-angle density of `direction`; 0 = no contribution
  bool delta = false;    // true for delta distributions (pdf is then 1)
};

// Samples a point on `light` as seen from p, with (u1,u2) in [0,1)^2.
LightSample sample_light(const Light& light, const V3f& p, float u1, float u2);

// Radiance of `light` along the ray (origin, dir) if it hits the emitter
// before tmax (for camera rays and for MIS in the path tracer), with the
// hit distance in *t and the solid-angle pdf of sample_light in *pdf.
// A DomeLight is hit only by rays that escape the scene: tmax = infinity,
// *t = infinity (server/scene/dome_light.h). UsdLuxShapingAPI is applied to
// the radiance of both functions (server/scene/light_shaping.h).
bool intersect_light(const Light& light, const V3f& origin, const V3f& dir, float tmax,
                     C3f* radiance, float* t, float* pdf);

// Total emitted power (watts), for choosing lights proportionally. Distant
// and dome lights, unbounded, give an irradiance (W/m^2) instead.
float light_power(const Light& light);

}  // namespace pbgi
