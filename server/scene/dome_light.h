// DomeLights: radiance arriving from infinitely far away in every
// direction, a constant colour or a lat-long map (environment_map.h)
// multiplied by Light::radiance.
//
// The dome's orientation is the rotation part of its local_to_world (scale,
// shear and translation are dropped: a dome has no size or position). A
// constant dome is sampled uniformly over the sphere (pdf 1 / 4pi), a mapped
// one by its importance distribution.
//
// Rays "hit" a dome only when they escape the scene: intersect_light()
// reports a dome for tmax = infinity (no surface hit), at t = infinity. That
// is what makes camera misses in the tile renderer and escaped paths in the
// reference path tracer see it.
//
// Thread-safety: all functions are reentrant.
#pragma once

#include "server/scene/light_sampling.h"

namespace pbgi {

// Light::kind must be LightKind::Dome for these.
LightSample sample_dome(const Light& light, float u1, float u2);
// Radiance from world direction `dir` (unit) and the solid-angle pdf with
// which sample_dome would have picked it.
C3f dome_radiance(const Light& light, const V3f& dir, float* pdf = nullptr);
// pi * mean radiance: the irradiance on a plane under a uniform dome of the
// mean radiance (W/m^2, the unit light_power uses for distant lights too).
float dome_power(const Light& light);

// Sum of the radiance of all DomeLights of the scene from world direction
// `dir` (unit): what a ray escaping the scene along dir sees.
C3f environment_radiance(const Scene& scene, const V3f& dir);

}  // namespace pbgi
