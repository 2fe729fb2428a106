// Primary rays of a USD camera (pinhole; USD's focalLength and apertures in
// mm, looking down -Z with +Y up in camera space).
#pragma once

#include "server/scene/scene.h"

#include <limits>

namespace pbgi {

struct Ray {
  V3f origin;
  V3f direction;  // unit
  // Valid hits lie in [tmin, tmax] along `direction`: camera_ray sets them
  // from the camera's clipping range (planes at depth near/far, so the
  // distance grows off-axis); other rays leave them unbounded.
  float tmin = 0.f;
  float tmax = std::numeric_limits<float>::infinity();
};

// Ray through image position (px, py) in pixels, y down from the top, for an
// image of width x height. The aperture is fitted to the image aspect ratio
// as USD's "fit horizontal" policy does; the aperture offsets shift the
// window on the film; tmin/tmax clip to the camera's clipping range.
Ray camera_ray(const Camera& camera, uint32_t width, uint32_t height, float px, float py);

}  // namespace pbgi
