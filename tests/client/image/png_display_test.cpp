#include "client/image/png_display.h"

#include "common/errors.h"

#include <gtest/gtest.h>
#include <png.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>

namespace pbgi::image {
namespace {

std::string temp_path(const std::string& name) {
  auto dir = std::filesystem::temp_directory_path() / "pbgi_test_client_image";
  std::filesystem::create_directories(dir);
  return (dir / name).string();
}

// The sRGB OETF (IEC 61966-2-1), to check the shipped config against.
float srgb_encode(float x) {
  return x <= 0.0031308f ? 12.92f * x : 1.055f * std::pow(x, 1.f / 2.4f) - 0.055f;
}

TEST(PngDisplay, ConfigIsFound) {
  std::string path = find_ocio_config();
  EXPECT_TRUE(std::filesystem::exists(path));
}

TEST(PngDisplay, DisplayTransformIsSrgb) {
  const std::vector<float> lin{0.f, 0.001f, 0.0031308f, 0.18f, 0.5f, 1.f, 4.f, -1.f, NAN};
  std::vector<float> rgb;
  for (float v : lin) rgb.insert(rgb.end(), {v, v, v});
  std::vector<uint8_t> out = display_rgb8(rgb, uint32_t(lin.size()), 1);
  ASSERT_EQ(out.size(), rgb.size());
  for (size_t i = 0; i < 7; ++i) {
    const float expected = std::min(1.f, srgb_encode(lin[i])) * 255.f;
    EXPECT_NEAR(out[3 * i], expected, 1.0) << "linear " << lin[i];
  }
  EXPECT_EQ(out[3 * 7], 0);  // negative clipped
  EXPECT_EQ(out[3 * 8], 0);  // NaN shown black
  // 0.5 -> 0.7354 -> 188 (a hand-checked value).
  EXPECT_EQ(out[3 * 4], 188);
}

TEST(PngDisplay, ExposureScalesLinearLight) {
  std::vector<float> rgb{0.25f, 0.25f, 0.25f};
  DisplayOptions opts;
  opts.exposure = 1.f;  // 0.25 * 2 = 0.5
  EXPECT_EQ(display_rgb8(rgb, 1, 1, opts)[0], 188);
}

TEST(PngDisplay, BadConfigOrViewThrows) {
  std::vector<float> rgb{0.5f, 0.5f, 0.5f};
  DisplayOptions opts;
  opts.view = "NoSuchView";
  EXPECT_THROW(display_rgb8(rgb, 1, 1, opts), Error);
  opts = {};
  opts.ocio_config = temp_path("missing.ocio");
  EXPECT_THROW(display_rgb8(rgb, 1, 1, opts), Error);
  EXPECT_THROW(display_rgb8(rgb, 2, 1), InvalidArgument);
}

TEST(PngDisplay, WrittenPngDecodes) {
  ExrImage img(7, 4);
  std::vector<float> rgb(img.pixel_count() * 3);
  for (size_t i = 0; i < img.pixel_count(); ++i) {
    rgb[3 * i] = 0.5f;
    rgb[3 * i + 1] = float(i) / float(img.pixel_count());
    rgb[3 * i + 2] = 0.f;
  }
  img.set_rgb("", rgb);
  img.set_layer("ao", y_channels(), std::vector<float>(img.pixel_count(), 1.f));
  const std::string path = temp_path("beauty.png");
  write_png(path, img);

  png_image png{};
  png.version = PNG_IMAGE_VERSION;
  ASSERT_TRUE(png_image_begin_read_from_file(&png, path.c_str())) << png.message;
  EXPECT_EQ(png.width, 7u);
  EXPECT_EQ(png.height, 4u);
  png.format = PNG_FORMAT_RGB;
  std::vector<uint8_t> pixels(PNG_IMAGE_SIZE(png));
  ASSERT_TRUE(png_image_finish_read(&png, nullptr, pixels.data(), 0, nullptr)) << png.message;
  EXPECT_EQ(pixels[0], 188);
  EXPECT_EQ(pixels[2], 0);
  EXPECT_LT(pixels[1], pixels[3 * 27 + 1]);  // green ramps up

  // A Y-only layer is written as grey; a missing layer is an error.
  write_png(temp_path("ao.png"), img, "ao");
  EXPECT_THROW(write_png(temp_path("none.png"), img, "nope"), NotFound);
  EXPECT_THROW(write_png("/nonexistent_dir/x.png", img), IoError);
}

TEST(PngDisplay, EnvironmentOverridesConfig) {
  const std::string fake = temp_path("env_config.ocio");
  std::filesystem::copy_file(find_ocio_config(), fake,
                             std::filesystem::copy_options::overwrite_existing);
  setenv("PBGI_OCIO_CONFIG", fake.c_str(), 1);
  EXPECT_EQ(find_ocio_config(), fake);
  unsetenv("PBGI_OCIO_CONFIG");
}

}  // namespace
}  // namespace pbgi::image
