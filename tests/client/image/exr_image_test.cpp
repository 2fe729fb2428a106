#include "client/image/exr_image.h"

#include "common/errors.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

namespace pbgi::image {
namespace {

std::string temp_path(const std::string& name) {
  auto dir = std::filesystem::temp_directory_path() / "pbgi_test_client_image";
  std::filesystem::create_directories(dir);
  return (dir / name).string();
}

// A 5x3 image with the full AOV layout and values that differ per pixel,
// channel and layer (so any mix-up shows).
ExrImage make_aov_image() {
  ExrImage img(5, 3);
  const char* layers[] = {"", "direct", "indirect", "albedo"};
  for (int l = 0; l < 4; ++l) {
    std::vector<float> rgb(img.pixel_count() * 3);
    for (size_t i = 0; i < rgb.size(); ++i) rgb[i] = float(l) * 100.f + float(i) * 0.37f - 1.f;
    img.set_rgb(layers[l], rgb);
  }
  std::vector<float> ao(img.pixel_count());
  for (size_t i = 0; i < ao.size(); ++i) ao[i] = float(i) / 15.f;
  img.set_layer("ao", y_channels(), ao);
  img.attributes()["pbgi/spp"] = "64";
  return img;
}

TEST(ExrImage, LayersAndChannelNames) {
  ExrImage img = make_aov_image();
  EXPECT_EQ(img.layer_names(), (std::vector<std::string>{"", "albedo", "ao", "direct", "indirect"}));
  EXPECT_EQ(img.layer_channels("direct"), (std::vector<std::string>{"R", "G", "B"}));
  EXPECT_EQ(img.layer_channels("ao"), (std::vector<std::string>{"Y"}));
  EXPECT_TRUE(img.has_channel("R"));
  EXPECT_TRUE(img.has_channel("indirect.G"));
  EXPECT_FALSE(img.has_layer("nope"));
  EXPECT_THROW(img.channel("nope.R"), NotFound);
  // Interleaved round trip through planar storage.
  std::vector<float> rgb = img.rgb("direct");
  ASSERT_EQ(rgb.size(), 45u);
  EXPECT_FLOAT_EQ(rgb[4], 100.f + 4 * 0.37f - 1.f);
  EXPECT_FLOAT_EQ(img.channel("direct.G")[1], rgb[4]);
}

TEST(ExrImage, SetRegionAssemblesTiles) {
  ExrImage img(4, 4);
  std::vector<float> tile(2 * 2 * 3, 7.f);
  img.set_region("indirect", rgb_channels(), 2, 2, 2, 2, tile.data());
  EXPECT_EQ(img.channel("indirect.B")[3 * 4 + 3], 7.f);
  EXPECT_EQ(img.channel("indirect.B")[0], 0.f);
  EXPECT_THROW(img.set_region("indirect", rgb_channels(), 3, 3, 2, 2, tile.data()),
               InvalidArgument);
  EXPECT_THROW(img.set_rgb("x", std::vector<float>(5)), InvalidArgument);
}

TEST(ExrImage, FloatRoundTripIsExact) {
  ExrImage img = make_aov_image();
  const std::string path = temp_path("roundtrip_float.exr");
  write_exr(path, img);
  ExrImage back = read_exr(path);
  EXPECT_EQ(back.width(), 5u);
  EXPECT_EQ(back.height(), 3u);
  EXPECT_EQ(back.channel_names(), img.channel_names());
  for (const std::string& name : img.channel_names())
    EXPECT_EQ(back.channel(name), img.channel(name)) << name;
  EXPECT_EQ(back.attributes().at("pbgi/spp"), "64");
  EXPECT_EQ(back.source_path(), path);
  EXPECT_FALSE(std::filesystem::exists(path + ".tmp"));
}

TEST(ExrImage, HalfRoundTripIsClose) {
  ExrImage img = make_aov_image();
  const std::string path = temp_path("roundtrip_half.exr");
  write_exr(path, img, {ExrPixelType::Half});
  ExrImage back = read_exr(path);
  for (const std::string& name : img.channel_names()) {
    const auto& a = img.channel(name);
    const auto& b = back.channel(name);
    for (size_t i = 0; i < a.size(); ++i)
      EXPECT_NEAR(b[i], a[i], std::abs(a[i]) * 1e-3f + 1e-4f) << name << " " << i;
  }
  EXPECT_LT(std::filesystem::file_size(path),
            std::filesystem::file_size(temp_path("roundtrip_float.exr")) + 1);
}

TEST(ExrImage, ErrorsNameTheFile) {
  const std::string missing = temp_path("does_not_exist.exr");
  try {
    read_exr(missing);
    FAIL();
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find(missing), std::string::npos);
  }
  const std::string junk = temp_path("junk.exr");
  std::ofstream(junk) << "this is not an exr file at all";
  try {
    read_exr(junk);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(junk), std::string::npos);
  }
  // A truncated file: valid header, missing pixel data.
  const std::string good = temp_path("to_truncate.exr");
  write_exr(good, make_aov_image());
  const std::string cut = temp_path("truncated.exr");
  std::filesystem::copy_file(good, cut, std::filesystem::copy_options::overwrite_existing);
  std::filesystem::resize_file(cut, std::filesystem::file_size(good) - 40);
  try {
    read_exr(cut);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(cut), std::string::npos);
  }
  EXPECT_THROW(write_exr(temp_path("empty.exr"), ExrImage(2, 2)), InvalidArgument);
  EXPECT_THROW(write_exr("/nonexistent_dir/x.exr", make_aov_image()), IoError);
}

}  // namespace
}  // namespace pbgi::image
