#include "server/surfels/spacing_field.h"

#include "server/scene/auto_camera.h"
#include "server/scene/scene_bulk.h"

#include "common/errors.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace pbgi {

SpacingField::SpacingField(const Scene& scene, const SurfelOptions& o) : adaptive_(true) {
  // A camera prim or "auto", the view a render of a scene without cameras gets.
  const float aspect = o.image_width > 0 && o.image_height > 0 ? float(o.image_width) / float(o.image_height) : 1.f;
  Camera resolved;
  try {
    resolved = resolve_camera(scene, o.camera, aspect);
  } catch (const NotFound& e) {
    throw InvalidArgument(fmt::format("surfels.camera = \"{}\": {}", o.camera, e.what()));
  }
  const Camera* cam = &resolved;
  if (!(cam->focal_length > 0.f) || !(cam->horizontal_aperture > 0.f)) {
    throw InvalidArgument(fmt::format("{}: camera {} has focal length {} and aperture {}: cannot derive a spacing",
                                      scene.source_path, o.camera, cam->focal_length, cam->horizontal_aperture));
  }
  cam->local_to_world.multVecMatrix(V3f(0, 0, 0), eye_);
  world_to_camera_ = cam->local_to_world.inverse();
  // The film as camera_rays.h fits it: horizontal aperture across the width.
  focal_ = cam->focal_length;
  const float film_w = cam->horizontal_aperture;
  const float film_h = film_w * float(o.image_height) / float(o.image_width);
  half_w_ = 0.5f * film_w * (1.f + o.frustum_margin);
  half_h_ = 0.5f * film_h * (1.f + o.frustum_margin);
  offset_x_ = cam->horizontal_aperture_offset;
  offset_y_ = cam->vertical_aperture_offset;
  per_distance_ = film_w / focal_ / float(o.image_width) * o.pixel_footprint;
  const Box3f bulk = scene_bulk(scene).bounds;  // a far outlier must not set the floor
  const V3f diag = bulk.isEmpty() ? V3f(1.f) : bulk.size();
  min_spacing_ = o.min_spacing > 0.f ? o.min_spacing : 1e-5f * diag.length();
  offscreen_ = o.offscreen_factor;
}

float SpacingField::camera_spacing(float distance) const {
  return std::max(min_spacing_, distance * per_distance_);
}

bool SpacingField::on_screen(const V3f& p) const {
  V3f c;
  world_to_camera_.multVecMatrix(p, c);
  const float depth = -c.z;
  if (!(depth > 0.f)) return false;
  const float x = focal_ * c.x / depth - offset_x_, y = focal_ * c.y / depth - offset_y_;
  return std::abs(x) <= half_w_ && std::abs(y) <= half_h_;
}

float SpacingField::at(const V3f& p) const {
  if (!adaptive_) return absolute_;
  const float h = camera_spacing((p - eye_).length());
  return on_screen(p) ? h : h * offscreen_;
}

float SpacingField::min_in(const Box3f& box) const {
  if (!adaptive_) return absolute_;
  V3f nearest;
  for (int k = 0; k < 3; ++k) nearest[k] = std::clamp(eye_[k], box.min[k], box.max[k]);
  return camera_spacing((nearest - eye_).length());
}

float SpacingField::max_in(const Box3f& box) const {
  if (!adaptive_) return absolute_;
  float far = 0.f;
  for (int k = 0; k < 3; ++k) far += std::max((box.min[k] - eye_[k]) * (box.min[k] - eye_[k]),
                                              (box.max[k] - eye_[k]) * (box.max[k] - eye_[k]));
  return camera_spacing(std::sqrt(far)) * offscreen_;
}

}  // namespace pbgi
