// The build flags parse into the request's BuildOptions: short payload
// names map onto codec names, a wavelet request is refused by name, the
// adaptive-spacing image comes from the rendered image.
#include "client/cli/build_flags.h"
#include "tests/client/cli/parse_flags.h"

#include "common/errors.h"

#include <gtest/gtest.h>

#include <vector>

namespace pbgi::cli {
namespace {

BuildArgs parse(std::vector<std::string> argv) {
  return testing::parse_flags<BuildArgs>(std::move(argv));
}

TEST(BuildFlags, PayloadNamesMapOntoCodecs) {
  EXPECT_EQ(parse({"--payload", "sh"}).to_proto().payload_codec(), "derived");
  EXPECT_EQ(parse({"--payload", "quantized"}).to_proto().payload_codec(), "kmeans-sh");
  EXPECT_EQ(parse({"--payload", "float32-sh"}).to_proto().payload_codec(), "float32-sh");
  EXPECT_EQ(parse({}).to_proto().payload_codec(), "");
  EXPECT_THROW(parse({"--payload", "wavelet"}).to_proto(), InvalidArgument);
}

TEST(BuildFlags, SamplerAndSpacingCamera) {
  const v1::BuildOptions plain = parse({"--sampler", "poisson"}).to_proto(640, 480);
  EXPECT_EQ(plain.sampler(), "poisson");
  EXPECT_EQ(plain.spacing_camera(), "");
  EXPECT_EQ(plain.spacing_image_width(), 0u);  // no camera: the image does not matter
  const v1::BuildOptions adaptive =
      parse({"--sampler", "poisson", "--spacing-camera", "/Cam", "--pixel-footprint", "1.5"})
          .to_proto(640, 480);
  EXPECT_EQ(adaptive.spacing_camera(), "/Cam");
  EXPECT_EQ(adaptive.spacing_image_width(), 640u);
  EXPECT_EQ(adaptive.spacing_image_height(), 480u);
  EXPECT_FLOAT_EQ(adaptive.pixel_footprint(), 1.5f);
  EXPECT_THROW(parse({"--sampler", "grid"}), CLI::ValidationError);
}

TEST(BuildFlags, GlossySenderFlagsAreSentOnlyWhenGiven) {
  const v1::BuildOptions none = parse({}).to_proto();
  EXPECT_FALSE(none.has_glossy_roughness());
  EXPECT_FALSE(none.has_wavelet_threshold());
  EXPECT_EQ(none.glossy_resolution(), 0u);
  const v1::BuildOptions set =
      parse({"--glossy-roughness", "0", "--glossy-resolution", "32", "--wavelet-threshold", "0.05"}).to_proto();
  ASSERT_TRUE(set.has_glossy_roughness());
  EXPECT_EQ(set.glossy_roughness(), 0.f);  // glossy senders off, not "the default"
  EXPECT_EQ(set.glossy_resolution(), 32u);
  EXPECT_FLOAT_EQ(set.wavelet_threshold(), 0.05f);
  EXPECT_THROW(parse({"--glossy-resolution", "12"}), CLI::ValidationError);
  EXPECT_THROW(parse({"--glossy-roughness", "2"}), CLI::ValidationError);
}

TEST(BuildFlags, LeafFormat) {
  EXPECT_EQ(parse({}).to_proto().leaf_format(), "");
  EXPECT_EQ(parse({"--leaf-format", "half"}).to_proto().leaf_format(), "half");
  EXPECT_THROW(parse({"--leaf-format", "A"}), CLI::ValidationError);
}

TEST(BuildFlags, FogFlagsAreSentOnlyWhenGiven) {
  EXPECT_FALSE(parse({}).to_proto().has_fog());
  const v1::BuildOptions fog = parse({"--fog-extinction", "2.5", "--fog-albedo", "0"}).to_proto();
  ASSERT_TRUE(fog.has_fog());
  EXPECT_FLOAT_EQ(fog.fog().extinction_per_density(), 2.5f);
  ASSERT_TRUE(fog.fog().has_albedo());
  EXPECT_EQ(fog.fog().albedo(), 0.f);  // absorbing, not "the default"
  EXPECT_THROW(parse({"--fog-albedo", "1.5"}), CLI::ValidationError);
  EXPECT_THROW(parse({"--fog-extinction", "0"}), CLI::ValidationError);
}

TEST(BuildFlags, BounceSplattingFlagsAreSentOnlyWhenGiven) {
  const v1::BuildOptions none = parse({}).to_proto();
  EXPECT_FALSE(none.has_bounce_splatting());
  EXPECT_FALSE(none.has_bounce_view_solid_angle());
  const v1::BuildOptions set =
      parse({"--bounces", "3", "--bounce-splatting", "false", "--bounce-view-solid-angle", "0"}).to_proto();
  EXPECT_EQ(set.bounces(), 3u);
  ASSERT_TRUE(set.has_bounce_splatting());
  EXPECT_FALSE(set.bounce_splatting());  // off, not "the default"
  ASSERT_TRUE(set.has_bounce_view_solid_angle());
  EXPECT_EQ(set.bounce_view_solid_angle(), 0.f);  // auto, not "the default"
  EXPECT_THROW(parse({"--bounce-view-solid-angle", "-0.1"}), CLI::ValidationError);
  EXPECT_THROW(parse({"--bounce-view-solid-angle", "1"}), CLI::ValidationError);
  EXPECT_THROW(parse({"--bounce-splatting", "maybe"}), CLI::ParseError);
}

TEST(BuildFlags, CoarseBounceFlagsAreSentOnlyWhenGiven) {
  const v1::BuildOptions none = parse({}).to_proto();
  EXPECT_FALSE(none.has_bounce_receiver_stride());
  EXPECT_FALSE(none.has_bounce_microbuffer_resolution());
  EXPECT_FALSE(none.has_bounce_max_solid_angle());
  const v1::BuildOptions full = parse({"--bounces", "4", "--bounce-receiver-stride", "1", "--bounce-mb-res", "8",
                                       "--bounce-solid-angle", "0.03"})
                                    .to_proto();
  ASSERT_TRUE(full.has_bounce_receiver_stride());
  EXPECT_EQ(full.bounce_receiver_stride(), 1u);
  ASSERT_TRUE(full.has_bounce_microbuffer_resolution());
  EXPECT_EQ(full.bounce_microbuffer_resolution(), 8u);
  ASSERT_TRUE(full.has_bounce_max_solid_angle());
  EXPECT_EQ(full.bounce_max_solid_angle(), 0.03f);
  EXPECT_THROW(parse({"--bounce-receiver-stride", "0"}), CLI::ValidationError);
  EXPECT_THROW(parse({"--bounce-receiver-stride", "65"}), CLI::ValidationError);
  EXPECT_THROW(parse({"--bounce-mb-res", "2"}), CLI::ValidationError);
  EXPECT_THROW(parse({"--bounce-solid-angle", "0"}), CLI::ValidationError);
}

}  // namespace
}  // namespace pbgi::cli
