#include "storage/codecs/cube_wavelet.h"

#include "common/errors.h"
#include "storage/codecs/haar_wavelet.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace pbgi::storage {

void CubeLayout::validate() const {
  if (!is_power_of_two(n) || n < kMinResolution || n > kMaxResolution) {
    throw InvalidArgument("cube map resolution " + std::to_string(n) + ": must be a power of two in [" +
                          std::to_string(kMinResolution) + ", " + std::to_string(kMaxResolution) + "]");
  }
}

Imath::V3f CubeLayout::direction(uint32_t face, uint32_t x, uint32_t y) const {
  const float u = -1.f + (2.f * float(x) + 1.f) / float(n);
  const float v = -1.f + (2.f * float(y) + 1.f) / float(n);
  Imath::V3f w;
  switch (face) {
    case 0: w = {1.f, -v, -u}; break;
    case 1: w = {-1.f, -v, u}; break;
    case 2: w = {u, 1.f, v}; break;
    case 3: w = {u, -1.f, -v}; break;
    case 4: w = {u, -v, 1.f}; break;
    default: w = {-u, -v, -1.f}; break;
  }
  return w.normalized();
}

void CubeLayout::pixel(const Imath::V3f& w, uint32_t& face, uint32_t& x, uint32_t& y) const {
  const float ax = std::abs(w.x), ay = std::abs(w.y), az = std::abs(w.z);
  float u, v, m;
  if (ax >= ay && ax >= az) {
    m = ax;
    face = w.x >= 0 ? 0 : 1;
    u = w.x >= 0 ? -w.z : w.z;
    v = -w.y;
  } else if (ay >= az) {
    m = ay;
    face = w.y >= 0 ? 2 : 3;
    u = w.x;
    v = w.y >= 0 ? w.z : -w.z;
  } else {
    m = az;
    face = w.z >= 0 ? 4 : 5;
    u = w.z >= 0 ? w.x : -w.x;
    v = -w.y;
  }
  if (!(m > 0.f)) throw InvalidArgument("cube map lookup of a zero or non-finite direction");
  u /= m;
  v /= m;
  auto to_pixel = [&](float t) {
    const int p = int(std::floor((t + 1.f) * 0.5f * float(n)));
    return uint32_t(std::clamp(p, 0, int(n) - 1));
  };
  x = to_pixel(u);
  y = to_pixel(v);
}

float CubeLayout::solid_angle(uint32_t x, uint32_t y) const {
  // Solid angle of [u0,u1] x [v0,v1] on the face plane at distance 1:
  // A(u1,v1) - A(u0,v1) - A(u1,v0) + A(u0,v0), A(a, b) = atan2(a b, sqrt(a^2 + b^2 + 1)).
  auto A = [](double a, double b) { return std::atan2(a * b, std::sqrt(a * a + b * b + 1.0)); };
  const double step = 2.0 / double(n);
  const double u0 = -1.0 + step * x, u1 = u0 + step, v0 = -1.0 + step * y, v1 = v0 + step;
  return float(A(u1, v1) - A(u0, v1) - A(u1, v0) + A(u0, v0));
}

std::vector<float> sample_cube(const CubeLayout& layout, const std::function<Imath::C3f(const Imath::V3f&)>& L) {
  layout.validate();
  std::vector<float> out(layout.floats());
  for (uint32_t f = 0; f < 6; ++f)
    for (uint32_t y = 0; y < layout.n; ++y)
      for (uint32_t x = 0; x < layout.n; ++x) {
        const Imath::C3f c = L(layout.direction(f, x, y));
        out[layout.index(f, 0, x, y)] = c.x;
        out[layout.index(f, 1, x, y)] = c.y;
        out[layout.index(f, 2, x, y)] = c.z;
      }
  return out;
}

namespace {
void check_size(const CubeLayout& layout, size_t size) {
  layout.validate();
  if (size != layout.floats()) {
    throw InvalidArgument("cube map of " + std::to_string(size) + " floats, expected " +
                          std::to_string(layout.floats()) + " for n = " + std::to_string(layout.n));
  }
}
}  // namespace

void cube_forward(const CubeLayout& layout, std::span<float> values) {
  check_size(layout, values.size());
  for (size_t img = 0; img < 18; ++img)
    haar2d_forward(values.subspan(img * layout.image_floats(), layout.image_floats()), layout.n);
}

void cube_inverse(const CubeLayout& layout, std::span<float> coeffs) {
  check_size(layout, coeffs.size());
  for (size_t img = 0; img < 18; ++img)
    haar2d_inverse(coeffs.subspan(img * layout.image_floats(), layout.image_floats()), layout.n);
}

Imath::C3f cube_evaluate(const CubeLayout& layout, std::span<const float> coeffs, const Imath::V3f& w) {
  check_size(layout, coeffs.size());
  uint32_t f, x, y;
  layout.pixel(w, f, x, y);
  Imath::C3f out;
  for (uint32_t c = 0; c < 3; ++c) {
    out[c] = haar2d_point(coeffs.subspan(layout.index(f, c, 0, 0), layout.image_floats()), layout.n, x, y);
  }
  return out;
}

Imath::C3f face_evaluate(const CubeLayout& layout, const float* face_coeffs, uint32_t x, uint32_t y) {
  const size_t img = layout.image_floats();
  Imath::C3f out;
  for (uint32_t c = 0; c < 3; ++c) out[c] = haar2d_point({face_coeffs + c * img, img}, layout.n, x, y);
  return out;
}

Imath::C3f glossy_radiance(const Imath::V3f& normal, const Imath::V3f& mirror, float roughness,
                           const Imath::C3f& kd, const Imath::C3f& ks, const Imath::V3f& w) {
  const float cos_n = normal.dot(w);
  if (cos_n <= 0.f) return {0.f, 0.f, 0.f};
  const float r = std::max(roughness, 1e-3f);
  const float e = std::max(0.f, 2.f / (r * r) - 2.f);
  const float c = std::max(0.f, mirror.dot(w));
  const float lobe = (e + 2.f) / (2.f * 3.14159265f) * std::pow(c, e);
  return kd * (1.f / 3.14159265f) + ks * lobe;
}

}  // namespace pbgi::storage
