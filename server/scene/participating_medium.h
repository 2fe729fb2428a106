// A participating medium the ray queries see: what fog (server/volumes,
// OpenVDB density grids) contributes to light transport besides surfaces.
// RayScene holds one optionally (RayScene::set_medium); direct lighting
// multiplies every unoccluded shadow ray by its transmittance, and the
// reference path tracer does the same on every path segment, so PBGI and
// the reference see the same extinction.
//
// Scattering: the reference path tracer also estimates single scattering
// of direct light inside the medium (sample_scatter(), albedo()) with an
// isotropic phase function, 1 / (4 pi) -- the phase the daemon's fog
// points assume (server/volumes/fog_points.h).
//
// An interface here keeps OpenVDB out of pbgi_scene; server/volumes
// implements it (fog_field.h). Implementations must be immutable and safe
// to call from many threads.
#pragma once

#include "server/scene/scene.h"

namespace pbgi {

// A scattering distance drawn along a ray (ParticipatingMedium::
// sample_scatter): for any g,
//   E[weight * g(t)] = integral over [tmin, tmax] of sigma_t(s) T(tmin, s) g(s) ds,
// so weight * albedo * phase * (light arriving at t) estimates the light
// scattered once toward the ray's origin. weight 0: nothing to scatter.
struct MediumScatter {
  float t = 0.f;
  float weight = 0.f;
};

class ParticipatingMedium {
 public:
  virtual ~ParticipatingMedium() = default;
  // exp(-optical depth) along origin + t dir, t in [tmin, tmax] (dir unit;
  // tmax may be infinite: the medium is bounded). 1 = clear.
  virtual float transmittance(const V3f& origin, const V3f& dir, float tmin, float tmax) const = 0;
  // False when there is nothing to attenuate (no grid, or empty grids):
  // callers skip the query.
  virtual bool empty() const = 0;
  // Single-scattering albedo sigma_s / sigma_t, the same everywhere in the
  // medium; black = purely absorbing.
  virtual C3f albedo() const = 0;
  // A distance in [tmin, tmax] (tmax may be infinite) drawn in proportion
  // to sigma_t(t) T(tmin, t) from the uniform numbers u_pick and u_distance
  // in [0, 1); see MediumScatter.
  virtual MediumScatter sample_scatter(const V3f& origin, const V3f& dir, float tmin, float tmax, float u_pick,
                                       float u_distance) const = 0;
};

}  // namespace pbgi
