// A DomeLight's lat-long radiance map, importance sampled.
//
// Mapping (OpenEXR's latitude-longitude convention, which UsdLux's
// DomeLight adopts): in the dome's local frame +Y is the top pole, the
// image's left edge is longitude +pi, its right edge -pi, its top row
// latitude +pi/2; latitude 0 / longitude 0 is +Z and longitude +pi/2 is +X.
// With u = (x + 0.5) / width and v = (y + 0.5) / height (y down):
//   theta = pi v (from +Y),  phi = pi (1 - 2u) (longitude),
//   dir = (sin theta sin phi, cos theta, sin theta cos phi).
//
// Radiance is piecewise constant over texels (no bilinear filtering), so
// that the sampling density below is exactly proportional to the sampled
// function's mean over rgb, up to the variation of sin(theta) inside a
// texel row: a map whose light comes from one texel is sampled with almost
// no variance (what remains comes from the receiver's cosine). The density is a piecewise-constant 2D distribution
// over (u, v) of mean(rgb) * sin(theta) (the solid angle of a texel row
// shrinks toward the poles); its solid-angle pdf is
//   pdf(dir) = pdf(u, v) / (2 pi^2 sin theta).
//
// Thread-safety: immutable after construction.
#pragma once

#include "server/scene/piecewise_constant.h"
#include "server/scene/scene.h"

#include <string>
#include <vector>

namespace pbgi {

class EnvironmentMap {
 public:
  // `texels`: width * height linear RGB values, row 0 at the top (the +Y
  // pole). Throws InvalidArgument for an empty or inconsistent image.
  EnvironmentMap(std::string name, uint32_t width, uint32_t height, std::vector<C3f> texels);

  const std::string& name() const { return name_; }
  uint32_t width() const { return width_; }
  uint32_t height() const { return height_; }

  // Radiance arriving from unit direction `dir` (dome-local frame).
  C3f eval(const V3f& dir) const;
  // A unit direction (dome-local) with solid-angle density *pdf and the
  // radiance from it in *radiance; (u1, u2) in [0,1)^2.
  V3f sample(float u1, float u2, float* pdf, C3f* radiance) const;
  // Solid-angle density of sample() for unit `dir`.
  float pdf(const V3f& dir) const;

  // Mean radiance over the sphere of directions (solid-angle weighted).
  const C3f& mean() const { return mean_; }

  // Lat-long coordinates of a unit direction and back (see the top).
  static Imath::V2f direction_to_uv(const V3f& dir);
  static V3f uv_to_direction(const Imath::V2f& uv);

 private:
  const C3f& at(const Imath::V2f& uv) const;

  std::string name_;
  uint32_t width_, height_;
  std::vector<C3f> texels_;
  PiecewiseConstant2D distribution_;
  C3f mean_{0, 0, 0};
};

}  // namespace pbgi
