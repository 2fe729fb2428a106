#include "client/metrics/perceptual_diff.h"

#include "common/errors.h"

#include <gtest/gtest.h>

#include <cmath>

namespace pbgi::metrics {
namespace {

constexpr uint32_t kW = 64, kH = 48;

std::vector<float> grey(float v) { return std::vector<float>(kW * kH * 3, v); }

void fill_square(std::vector<float>& rgb, uint32_t x0, uint32_t y0, uint32_t size,
                 float r, float g, float b) {
  for (uint32_t y = y0; y < y0 + size; ++y)
    for (uint32_t x = x0; x < x0 + size; ++x) {
      float* p = &rgb[3 * (size_t(y) * kW + x)];
      p[0] = r;
      p[1] = g;
      p[2] = b;
    }
}

TEST(PerceptualDiff, IdenticalImagesDoNotDiffer) {
  std::vector<float> img = grey(0.3f);
  fill_square(img, 10, 10, 8, 2.f, 0.1f, 0.5f);
  const PerceptualResult r = perceptual_diff(img, img, kW, kH);
  EXPECT_EQ(r.pixels, uint64_t(kW) * kH);
  EXPECT_EQ(r.pixels_different, 0u);
  EXPECT_EQ(r.fraction_different, 0.0);
}

TEST(PerceptualDiff, VisibleSquareIsFoundWhereItIs) {
  const std::vector<float> ref = grey(0.3f);
  std::vector<float> test = ref;
  fill_square(test, 20, 16, 12, 0.6f, 0.6f, 0.6f);  // twice as bright: obvious
  PerceptualOptions o;
  o.want_map = true;
  const PerceptualResult r = perceptual_diff(test, ref, kW, kH, o);
  EXPECT_GE(r.pixels_different, 12u * 12u / 2);
  EXPECT_LE(r.pixels_different, 20u * 20u);
  EXPECT_EQ(r.map[size_t(22) * kW + 26], 1);  // inside the square
  EXPECT_EQ(r.map[0], 0);                     // far from it
}

TEST(PerceptualDiff, DifferencesBelowThresholdAreForgiven) {
  // 0.2% brighter everywhere: below the luminance threshold (Weber ~1%).
  const std::vector<float> ref = grey(0.3f);
  const std::vector<float> test = grey(0.3f * 1.002f);
  EXPECT_EQ(perceptual_diff(test, ref, kW, kH).pixels_different, 0u);
  // 10% brighter everywhere: visible.
  EXPECT_EQ(perceptual_diff(grey(0.33f), ref, kW, kH).pixels_different, uint64_t(kW) * kH);
}

TEST(PerceptualDiff, ColorTestCatchesIsoluminantChanges) {
  // Same luminance Y, different chromaticity.
  const float y = 0.3f;
  std::vector<float> ref = grey(y), test = ref;
  const float r = 0.5f, b = 0.3f;
  const float g = (y - 0.2126f * r - 0.0722f * b) / 0.7152f;
  fill_square(test, 0, 0, kW < kH ? kW : kH, r, g, b);
  PerceptualOptions o;
  EXPECT_GT(perceptual_diff(test, ref, kW, kH, o).pixels_different, 100u);
  o.luminance_only = true;
  EXPECT_EQ(perceptual_diff(test, ref, kW, kH, o).pixels_different, 0u);
}

TEST(PerceptualDiff, RejectsBadInput) {
  EXPECT_THROW(perceptual_diff(grey(0.f), std::vector<float>(3), kW, kH), InvalidArgument);
  PerceptualOptions o;
  o.field_of_view_degrees = 0.f;
  EXPECT_THROW(perceptual_diff(grey(0.f), grey(0.f), kW, kH, o), InvalidArgument);
}

}  // namespace
}  // namespace pbgi::metrics
