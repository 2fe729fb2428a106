// A participating medium the ray queries see: what fog (server/volumes,
// OpenVDB density grids) contributes to light transport besides surfaces.
// RayScene holds one optionally (RayScene::set_medium); direct lighting
// multiplies every unoccluded shadow ray by its transmittance, and the
// reference path tracer does the same on every path segment, so PBGI and
// the reference see the same extinction.
//
// An interface here keeps OpenVDB out of pbgi_scene; server/volumes
// implements it (fog_field.h). Implementations must be immutable and safe
// to call from many threads.
#pragma once

#include "server/scene/scene.h"

namespace pbgi {

class ParticipatingMedium {
 public:
  virtual ~ParticipatingMedium() = default;
  // exp(-optical depth) along origin + t dir, t in [tmin, tmax] (dir unit;
  // tmax may be infinite: the medium is bounded). 1 = clear.
  virtual float transmittance(const V3f& origin, const V3f& dir, float tmin, float tmax) const = 0;
  // False when there is nothing to attenuate (no grid, or empty grids):
  // callers skip the query.
  virtual bool empty() const = 0;
};

}  // namespace pbgi
