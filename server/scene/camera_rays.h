// Primary rays of a USD camera (pinhole; USD's focalLength and apertures in
// mm, looking down -Z with +Y up in camera space).
#pragma once

#include "server/scene/scene.h"

namespace pbgi {

struct Ray {
  V3f origin;
  V3f direction;  // unit
};

// Ray through image position (px, py) in pixels, y down from the top, for an
// image of width x height. The aperture is fitted to the image aspect ratio
// as USD's "fit horizontal" policy does.
Ray camera_ray(const Camera& camera, uint32_t width, uint32_t height, float px, float py);

}  // namespace pbgi
