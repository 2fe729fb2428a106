#include "client/metrics/image_comparison.h"

#include "common/errors.h"

#include <gtest/gtest.h>

#include <cmath>

namespace pbgi::metrics {
namespace {

image::ExrImage aov_image(uint32_t w, uint32_t h, float beauty, float indirect, float ao) {
  image::ExrImage img(w, h);
  img.set_rgb("", std::vector<float>(img.pixel_count() * 3, beauty));
  img.set_rgb("indirect", std::vector<float>(img.pixel_count() * 3, indirect));
  img.set_layer("ao", image::y_channels(), std::vector<float>(img.pixel_count(), ao));
  return img;
}

TEST(ImageComparison, EveryCommonLayerIsCompared) {
  const image::ExrImage ref = aov_image(16, 8, 1.f, 0.5f, 1.f);
  image::ExrImage test = aov_image(16, 8, 1.f, 0.6f, 0.5f);
  test.set_rgb("albedo", std::vector<float>(test.pixel_count() * 3, 0.5f));  // not in ref
  const std::vector<AovMetrics> all = compare_images(test, ref);
  ASSERT_EQ(all.size(), 3u);
  EXPECT_EQ(all[0].layer, "");
  EXPECT_EQ(all[0].error.mse, 0.0);
  EXPECT_EQ(all[0].perceptual->pixels_different, 0u);
  EXPECT_EQ(all[1].layer, "ao");
  EXPECT_EQ(all[1].channels, std::vector<std::string>{"Y"});
  EXPECT_NEAR(all[1].error.mse, 0.25, 1e-9);
  ASSERT_TRUE(all[1].perceptual.has_value());  // grey groups get it too
  EXPECT_EQ(all[2].layer, "indirect");
  EXPECT_EQ(all[2].channels, (std::vector<std::string>{"R", "G", "B"}));
  EXPECT_NEAR(all[2].error.mse, 0.01, 1e-7);
  EXPECT_NEAR(all[2].error.psnr, 10 * std::log10(0.25 / 0.01), 1e-4);
}

TEST(ImageComparison, LayerCanBeMatchedToAnotherName) {
  image::ExrImage ref = aov_image(4, 4, 1.f, 0.5f, 1.f);
  ref.set_rgb("indirect1", std::vector<float>(ref.pixel_count() * 3, 0.6f));
  const image::ExrImage test = aov_image(4, 4, 1.f, 0.6f, 1.f);
  const AovMetrics m = compare_layer(test, ref, "indirect", {}, "indirect1");
  EXPECT_EQ(m.reference_layer, "indirect1");
  EXPECT_EQ(m.error.mse, 0.0);
}

TEST(ImageComparison, MismatchesAreErrorsNamingTheImages) {
  image::ExrImage ref = aov_image(4, 4, 1.f, 0.5f, 1.f);
  ref.set_source_path("ref.exr");
  image::ExrImage small = aov_image(4, 3, 1.f, 0.5f, 1.f);
  small.set_source_path("test.exr");
  try {
    compare_images(small, ref);
    FAIL();
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("test.exr"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("ref.exr"), std::string::npos);
  }
  const image::ExrImage test = aov_image(4, 4, 1.f, 0.5f, 1.f);
  EXPECT_THROW(compare_layer(test, ref, "direct"), NotFound);
}

}  // namespace
}  // namespace pbgi::metrics
