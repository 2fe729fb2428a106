#include "server/scene/environment_map.h"

#include "common/errors.h"
#include "server/scene/sample_patterns.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace pbgi {

EnvironmentMap::EnvironmentMap(std::string name, uint32_t width, uint32_t height, std::vector<C3f> texels)
    : name_(std::move(name)), width_(width), height_(height), texels_(std::move(texels)) {
  if (width == 0 || height == 0 || texels_.size() != size_t(width) * height) {
    throw InvalidArgument(fmt::format("environment map '{}': {} texels for {}x{}", name_, texels_.size(),
                                      width, height));
  }
  std::vector<float> density(texels_.size());
  double sum[3] = {0, 0, 0}, weight = 0.0;
  for (uint32_t y = 0; y < height; ++y) {
    // Exact solid angle of the row's texels: 2pi/width * (cos t0 - cos t1).
    const double t0 = kPi * double(y) / height, t1 = kPi * double(y + 1) / height;
    const double row_solid_angle = (std::cos(t0) - std::cos(t1)) * 2.0 * kPi / width;
    const float sin_theta = std::sin(kPi * (float(y) + 0.5f) / float(height));
    for (uint32_t x = 0; x < width; ++x) {
      C3f& c = texels_[size_t(y) * width + x];
      for (int k = 0; k < 3; ++k)
        if (!std::isfinite(c[k]) || c[k] < 0.f) c[k] = 0.f;  // no negative or NaN light
      density[size_t(y) * width + x] = (c.x + c.y + c.z) / 3.f * sin_theta;
      for (int k = 0; k < 3; ++k) sum[k] += c[k] * row_solid_angle;
    }
    weight += row_solid_angle * width;
  }
  mean_ = C3f(float(sum[0] / weight), float(sum[1] / weight), float(sum[2] / weight));
  distribution_ = PiecewiseConstant2D(density, width, height);
}

Imath::V2f EnvironmentMap::direction_to_uv(const V3f& d) {
  const float theta = std::acos(std::clamp(d.y, -1.f, 1.f));
  const float phi = std::atan2(d.x, d.z);  // longitude in [-pi, pi]
  float u = 0.5f - phi / (2.f * kPi);
  u -= std::floor(u);
  return {u, theta / kPi};
}

V3f EnvironmentMap::uv_to_direction(const Imath::V2f& uv) {
  const float theta = kPi * uv.y, phi = kPi * (1.f - 2.f * uv.x);
  const float st = std::sin(theta);
  return V3f(st * std::sin(phi), std::cos(theta), st * std::cos(phi));
}

const C3f& EnvironmentMap::at(const Imath::V2f& uv) const {
  const uint32_t x = std::min(uint32_t(std::max(0.f, uv.x * float(width_))), width_ - 1);
  const uint32_t y = std::min(uint32_t(std::max(0.f, uv.y * float(height_))), height_ - 1);
  return texels_[size_t(y) * width_ + x];
}

C3f EnvironmentMap::eval(const V3f& dir) const { return at(direction_to_uv(dir)); }

V3f EnvironmentMap::sample(float u1, float u2, float* pdf, C3f* radiance) const {
  float pdf_uv = 0.f;
  const Imath::V2f uv = distribution_.sample(u1, u2, &pdf_uv);
  const float sin_theta = std::sin(kPi * uv.y);
  *pdf = sin_theta > 0.f ? pdf_uv / (2.f * kPi * kPi * sin_theta) : 0.f;
  *radiance = at(uv);
  return uv_to_direction(uv);
}

float EnvironmentMap::pdf(const V3f& dir) const {
  const Imath::V2f uv = direction_to_uv(dir);
  const float sin_theta = std::sin(kPi * uv.y);
  if (!(sin_theta > 0.f)) return 0.f;
  return distribution_.pdf(uv) / (2.f * kPi * kPi * sin_theta);
}

}  // namespace pbgi
