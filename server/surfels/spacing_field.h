// The target spacing of surfels at each point of the scene: one absolute
// value, or camera-adaptive (SurfelOptions::camera): the width a surfel
// must have to cover `pixel_footprint` pixels where it is seen,
//   h(p) = max(min_spacing, |p - eye| * pixel_angle * pixel_footprint),
// times offscreen_factor outside the (margin-widened) frustum, so surfaces
// off screen, which only light what is seen, get a coarser sampling.
//
// Thread-safety: immutable after construction.
#pragma once

#include "server/scene/scene.h"
#include "server/surfels/surfel_options.h"

namespace pbgi {

class SpacingField {
 public:
  // Absolute spacing.
  explicit SpacingField(float spacing) : absolute_(spacing) {}
  // Camera-adaptive; throws InvalidArgument if the scene has no such camera
  // or its projection is degenerate.
  SpacingField(const Scene& scene, const SurfelOptions& options);

  bool adaptive() const { return adaptive_; }
  float at(const V3f& p) const;
  // Bounds of at() over a box: the smallest assumes the box is on screen at
  // its nearest point, the largest off screen at its farthest.
  float min_in(const Box3f& box) const;
  float max_in(const Box3f& box) const;
  bool on_screen(const V3f& p) const;

 private:
  float camera_spacing(float distance) const;

  bool adaptive_ = false;
  float absolute_ = 0.f;
  V3f eye_{0, 0, 0};
  M44f world_to_camera_;
  float focal_ = 1.f, half_w_ = 1.f, half_h_ = 1.f, offset_x_ = 0.f, offset_y_ = 0.f;
  float per_distance_ = 0.f;  // pixel angle x footprint
  float min_spacing_ = 0.f, offscreen_ = 1.f;
};

}  // namespace pbgi
