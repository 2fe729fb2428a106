#include "server/scene/auto_camera.h"

#include "server/scene/scene_bulk.h"

#include "common/errors.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

namespace pbgi {

Camera auto_camera(const Scene& scene, float aspect) {
  Box3f box = scene_bulk(scene).bounds;  // not a far outlier's box
  for (const Volume& v : scene.volumes) box.extendBy(v.bounds);  // fog has no triangles
  return auto_camera(box, scene.up_axis, aspect);
}

Camera auto_camera(const Box3f& bounds, const std::string& up_axis, float aspect) {
  if (!(aspect > 0.f) || !std::isfinite(aspect))
    throw InvalidArgument(fmt::format("auto camera: aspect ratio {} must be finite and > 0", aspect));
  V3f center(0.f), half(1.f / std::sqrt(3.f));
  if (!bounds.isEmpty()) {
    center = bounds.center();
    half = bounds.size() * 0.5f;
  }
  // A flat or point-like scene still needs a finite distance.
  const float radius = std::max(half.length(), 1e-6f * std::max(1.f, center.length()));

  // Direction from the centre to the eye in a Y-up frame, then mapped to the
  // stage's up axis: Y-up (x, y, z) -> Z-up (x, -z, y) keeps the same side
  // of a model authored either way in front of the camera.
  const float az = kAutoCameraAzimuthDegrees * float(M_PI) / 180.f;
  const float el = kAutoCameraElevationDegrees * float(M_PI) / 180.f;
  V3f back(std::sin(az) * std::cos(el), std::sin(el), std::cos(az) * std::cos(el));
  V3f up(0.f, 1.f, 0.f);
  if (up_axis == "Z") {
    back = V3f(back.x, -back.z, back.y);
    up = V3f(0.f, 0.f, 1.f);
  }

  Camera c;
  c.prim_path = kAutoCameraPath;
  c.vertical_aperture = c.horizontal_aperture / aspect;
  // Half-angle of the narrower side of the film (fit horizontal: the
  // vertical film is horizontal / aspect, as camera_ray renders it).
  const float half_film = 0.5f * std::min(c.horizontal_aperture, c.vertical_aperture);
  const float half_angle = std::atan(half_film / c.focal_length);
  const float framed = radius * kAutoCameraMargin;
  const float distance = framed / std::sin(half_angle);
  const V3f eye = center + back * distance;

  // Rows: camera X, Y, Z (Z = back, the camera looks down -Z), then the eye.
  const V3f z = back;
  const V3f x = up.cross(z).normalized();
  const V3f y = z.cross(x);
  c.local_to_world = M44f(x.x, x.y, x.z, 0.f, y.x, y.y, y.z, 0.f, z.x, z.y, z.z, 0.f, eye.x, eye.y, eye.z, 1.f);
  c.near_clip = std::max((distance - framed) * 0.5f, distance * 1e-5f);
  c.far_clip = (distance + framed) * 2.f;
  return c;
}

Camera resolve_camera(const Scene& scene, const std::string& path, float aspect) {
  if (const Camera* c = scene.find_camera(path)) return *c;
  if (path == kAutoCameraPath || (path.empty() && scene.cameras.empty())) return auto_camera(scene, aspect);
  if (path.empty() && scene.cameras.size() == 1) return scene.cameras.begin()->second;
  std::string known;
  for (const auto& [name, camera] : scene.cameras) known += name + ", ";
  throw NotFound(fmt::format("{}: {} (cameras in the scene: {}{})", scene.source_path,
                             path.empty() ? "several cameras, pass --camera" : "no camera '" + path + "'",
                             known, kAutoCameraPath));
}

}  // namespace pbgi
