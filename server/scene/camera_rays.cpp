#include "server/scene/camera_rays.h"

namespace pbgi {

// USD's pinhole: the film (aperture, in the same units as focalLength) sits
// at distance focalLength in front of the eye; a film point (x, y) maps to
// the camera-space direction (x, y, -focalLength). Fitting horizontally
// keeps horizontalAperture across the image width and derives the vertical
// extent from the image's aspect ratio (pixels are square).
Ray camera_ray(const Camera& camera, uint32_t width, uint32_t height, float px, float py) {
  const float w = static_cast<float>(width), h = static_cast<float>(height);
  const float film_w = camera.horizontal_aperture;
  const float film_h = camera.horizontal_aperture * h / w;
  const float x = (px / w - 0.5f) * film_w + camera.horizontal_aperture_offset;
  const float y = (0.5f - py / h) * film_h + camera.vertical_aperture_offset;
  const V3f d_cam(x, y, -camera.focal_length);

  Ray ray;
  camera.local_to_world.multVecMatrix(V3f(0, 0, 0), ray.origin);
  camera.local_to_world.multDirMatrix(d_cam, ray.direction);
  // d_cam reaches depth focal_length; its world length (the transform may
  // scale) converts the clipping depths into distances along this ray.
  const float world_length = ray.direction.length();
  ray.direction /= world_length;
  if (camera.focal_length > 0.f) {
    const float per_depth = world_length / camera.focal_length;
    ray.tmin = camera.near_clip > 0.f ? camera.near_clip * per_depth : 0.f;
    if (camera.far_clip > camera.near_clip) ray.tmax = camera.far_clip * per_depth;
  }
  return ray;
}

}  // namespace pbgi
