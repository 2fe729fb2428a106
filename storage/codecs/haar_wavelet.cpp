#include "storage/codecs/haar_wavelet.h"

#include "common/errors.h"

#include <string>
#include <vector>

namespace pbgi::storage {

namespace {

constexpr float kInvSqrt2 = 0.70710678118654752f;

void check(size_t size, uint32_t n) {
  if (!is_power_of_two(n) || size != size_t(n) * n) {
    throw InvalidArgument("Haar transform: " + std::to_string(size) + " values for a " + std::to_string(n) +
                          " x " + std::to_string(n) + " image (n must be a power of two)");
  }
}

// One analysis step on k values spaced `stride` apart.
void step_forward(float* p, size_t stride, uint32_t k, float* tmp) {
  const uint32_t s = k / 2;
  for (uint32_t j = 0; j < s; ++j) {
    const float a = p[(2 * j) * stride], b = p[(2 * j + 1) * stride];
    tmp[j] = (a + b) * kInvSqrt2;
    tmp[s + j] = (a - b) * kInvSqrt2;
  }
  for (uint32_t j = 0; j < k; ++j) p[j * stride] = tmp[j];
}

void step_inverse(float* p, size_t stride, uint32_t k, float* tmp) {
  const uint32_t s = k / 2;
  for (uint32_t j = 0; j < s; ++j) {
    const float a = p[j * stride], d = p[(s + j) * stride];
    tmp[2 * j] = (a + d) * kInvSqrt2;
    tmp[2 * j + 1] = (a - d) * kInvSqrt2;
  }
  for (uint32_t j = 0; j < k; ++j) p[j * stride] = tmp[j];
}

}  // namespace

void haar2d_forward(std::span<float> img, uint32_t n) {
  check(img.size(), n);
  std::vector<float> tmp(n);
  for (uint32_t k = n; k >= 2; k /= 2) {
    for (uint32_t row = 0; row < k; ++row) step_forward(&img[size_t(row) * n], 1, k, tmp.data());
    for (uint32_t col = 0; col < k; ++col) step_forward(&img[col], n, k, tmp.data());
  }
}

void haar2d_inverse(std::span<float> c, uint32_t n) {
  check(c.size(), n);
  std::vector<float> tmp(n);
  for (uint32_t k = 2; k <= n; k *= 2) {
    for (uint32_t col = 0; col < k; ++col) step_inverse(&c[col], n, k, tmp.data());
    for (uint32_t row = 0; row < k; ++row) step_inverse(&c[size_t(row) * n], 1, k, tmp.data());
  }
}

float haar2d_point(std::span<const float> c, uint32_t n, uint32_t x, uint32_t y) {
  check(c.size(), n);
  if (x >= n || y >= n) {
    throw InvalidArgument("Haar point (" + std::to_string(x) + ", " + std::to_string(y) + ") outside a " +
                          std::to_string(n) + " x " + std::to_string(n) + " image");
  }
  // Undo the levels from the coarsest (k = 2) down: at block size k the
  // pixel's ancestor is (x >> shift, y >> shift); its parent in the k/2 grid
  // carries the running value. Each level combines the average with the
  // three details at the parent's position; signs follow the pixel's parity.
  float v = c[0];
  int shift = 0;
  while ((n >> shift) > 1) ++shift;
  for (uint32_t k = 2; k <= n; k *= 2) {
    --shift;
    const uint32_t s = k / 2;
    const uint32_t xk = x >> shift, yk = y >> shift;
    const uint32_t i = yk >> 1, j = xk >> 1;
    const float sx = (xk & 1) ? -1.f : 1.f, sy = (yk & 1) ? -1.f : 1.f;
    const float dx = c[size_t(i) * n + s + j];        // detail along x
    const float dy = c[size_t(s + i) * n + j];        // detail along y
    const float dxy = c[size_t(s + i) * n + s + j];   // both
    v = 0.5f * (v + sx * dx + sy * dy + sx * sy * dxy);
  }
  return v;
}

}  // namespace pbgi::storage
