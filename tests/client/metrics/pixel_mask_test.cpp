// Region comparisons: the pixels of one value of a mask layer, gathered
// into a strip that the usual metrics measure alone.
#include "client/metrics/pixel_mask.h"
#include "client/metrics/image_comparison.h"
#include "common/errors.h"

#include <gtest/gtest.h>

#include <vector>

namespace pbgi::metrics {
namespace {

TEST(PixelMask, SelectsThePixelsOfOneValueAndMeasuresThemAlone) {
  // 3 x 2 image; albedo 0.9 at pixels 1 and 4, 0.5 elsewhere.
  image::ExrImage mask(3, 2);
  std::vector<float> albedo(3 * 6, 0.5f);
  for (const int p : {1, 4})
    for (int c = 0; c < 3; ++c) albedo[3 * p + c] = 0.9f;
  mask.set_rgb("albedo", albedo);
  const std::vector<uint32_t> pixels = pixels_where(mask, "albedo", 0.9f, 1e-3f);
  ASSERT_EQ(pixels, (std::vector<uint32_t>{1, 4}));

  image::ExrImage test(3, 2), reference(3, 2);
  std::vector<float> t(3 * 6, 1.f), r(3 * 6, 1.f);
  for (int c = 0; c < 3; ++c) {
    t[3 * 1 + c] = 3.f;  // selected: error 2
    t[3 * 2 + c] = 9.f;  // not selected: must not count
  }
  test.set_rgb("indirect", t);
  reference.set_rgb("indirect", r);
  const image::ExrImage ts = select_pixels(test, pixels), rs = select_pixels(reference, pixels);
  EXPECT_EQ(ts.width(), 2u);
  EXPECT_EQ(ts.height(), 1u);
  ComparisonOptions o;
  o.perceptual = false;
  const AovMetrics m = compare_layer(ts, rs, "indirect", o);
  EXPECT_DOUBLE_EQ(m.error.mse, 2.0);  // (4 + 0) / 2 per channel

  EXPECT_THROW(pixels_where(mask, "nope", 0.9f, 1e-3f), NotFound);
  EXPECT_THROW(select_pixels(test, {}), InvalidArgument);
  EXPECT_THROW(select_pixels(test, {6}), InvalidArgument);
}

}  // namespace
}  // namespace pbgi::metrics
