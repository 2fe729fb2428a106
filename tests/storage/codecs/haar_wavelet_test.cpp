#include "storage/codecs/haar_wavelet.h"
#include "common/errors.h"
#include "storage/codecs/cube_wavelet.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace pbgi::storage {
namespace {

std::vector<float> random_image(uint32_t n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.f, 4.f);
  std::vector<float> v(size_t(n) * n);
  for (auto& x : v) x = u(rng);
  return v;
}

TEST(Haar2d, RoundTripIsExactWithoutThresholding) {
  for (uint32_t n : {1u, 2u, 4u, 8u, 16u, 32u}) {
    const auto img = random_image(n, n);
    auto c = img;
    haar2d_forward(c, n);
    // Orthonormal: energy preserved.
    double e_img = 0, e_c = 0;
    for (size_t i = 0; i < img.size(); ++i) {
      e_img += double(img[i]) * img[i];
      e_c += double(c[i]) * c[i];
    }
    EXPECT_NEAR(e_c, e_img, 1e-5 * e_img);
    // (0, 0) is the mean times n.
    double mean = 0;
    for (float x : img) mean += x;
    mean /= double(img.size());
    EXPECT_NEAR(c[0], mean * n, 1e-4 * n);
    // Point evaluation gives each pixel without the full inverse.
    for (uint32_t y = 0; y < n; ++y)
      for (uint32_t x = 0; x < n; ++x) ASSERT_NEAR(haar2d_point(c, n, x, y), img[y * n + x], 2e-5f) << n;
    haar2d_inverse(c, n);
    for (size_t i = 0; i < img.size(); ++i) ASSERT_NEAR(c[i], img[i], 2e-5f) << n << " " << i;
  }
}

TEST(Haar2d, PiecewiseConstantImageIsSparse) {
  // Constant quadrants: every detail below the coarsest level is zero.
  const uint32_t n = 16;
  std::vector<float> img(n * n);
  for (uint32_t y = 0; y < n; ++y)
    for (uint32_t x = 0; x < n; ++x) img[y * n + x] = (x < 8) == (y < 8) ? 2.f : 1.f;
  auto c = img;
  haar2d_forward(c, n);
  int nonzero = 0;
  for (float v : c) nonzero += std::abs(v) > 1e-6f;
  EXPECT_LE(nonzero, 4);  // the average and the coarsest details only: sparse
  haar2d_inverse(c, n);
  for (size_t i = 0; i < img.size(); ++i) EXPECT_NEAR(c[i], img[i], 1e-6f);
}

TEST(Haar2d, RejectsBadSizes) {
  std::vector<float> v(12);
  EXPECT_THROW(haar2d_forward(v, 3), InvalidArgument);
  std::vector<float> w(16);
  EXPECT_THROW(haar2d_forward(w, 8), InvalidArgument);
  EXPECT_THROW(haar2d_point(w, 4, 4, 0), InvalidArgument);
}

TEST(CubeWavelet, DirectionsAndPixelsAgree) {
  const CubeLayout layout{16};
  for (uint32_t f = 0; f < 6; ++f)
    for (uint32_t y = 0; y < 16; ++y)
      for (uint32_t x = 0; x < 16; ++x) {
        uint32_t f2, x2, y2;
        layout.pixel(layout.direction(f, x, y), f2, x2, y2);
        ASSERT_EQ(f2, f);
        ASSERT_EQ(x2, x);
        ASSERT_EQ(y2, y);
      }
  EXPECT_THROW(CubeLayout{12}.validate(), InvalidArgument);
  EXPECT_THROW(CubeLayout{64}.validate(), InvalidArgument);
  EXPECT_THROW(CubeLayout{4}.validate(), InvalidArgument);
}

TEST(CubeWavelet, GlossyLobeRoundTripAndPointEvaluation) {
  const CubeLayout layout{32};
  const Imath::V3f n(0, 0, 1), mirror = Imath::V3f(1, 0, 1).normalized();
  auto L = [&](const Imath::V3f& w) {
    return glossy_radiance(n, mirror, 0.2f, {0.2f, 0.2f, 0.2f}, {1.f, 0.8f, 0.5f}, w);
  };
  const auto values = sample_cube(layout, L);
  auto c = values;
  cube_forward(layout, c);
  for (uint32_t f = 0; f < 6; ++f)
    for (uint32_t y = 0; y < 32; y += 3)
      for (uint32_t x = 0; x < 32; x += 5) {
        const Imath::V3f w = layout.direction(f, x, y);
        const Imath::C3f got = cube_evaluate(layout, c, w), want = L(w);
        for (int k = 0; k < 3; ++k) ASSERT_NEAR(got[k], want[k], 1e-4f * (1 + want[k]));
      }
  cube_inverse(layout, c);
  for (size_t i = 0; i < values.size(); ++i) ASSERT_NEAR(c[i], values[i], 1e-4f * (1 + values[i]));
}

}  // namespace
}  // namespace pbgi::storage
