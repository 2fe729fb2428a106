// The gather flags `pbgi render` and `pbgi tile` share parse into the
// request's GatherOptions; unset flags stay 0 (= the daemon's default).
#include "client/cli/gather_flags.h"
#include "tests/client/cli/parse_flags.h"

#include <gtest/gtest.h>

#include <vector>

namespace pbgi::cli {
namespace {

v1::GatherOptions parse(std::vector<std::string> argv) {
  return testing::parse_flags<GatherArgs>(std::move(argv)).to_proto();
}

TEST(GatherFlags, UnsetFlagsLeaveTheDaemonDefaults) {
  const v1::GatherOptions o = parse({});
  EXPECT_EQ(o.microbuffer_resolution(), 0u);
  EXPECT_EQ(o.max_solid_angle(), 0.f);
  EXPECT_EQ(o.method(), v1::GatherOptions::METHOD_DEFAULT);
  EXPECT_EQ(o.clusters(), 0u);
  EXPECT_EQ(o.glossy_max_resolution(), 0u);
  EXPECT_EQ(o.glossy_importance(), 0.f);
  EXPECT_FALSE(o.has_glossy_radiance_weight());
}

TEST(GatherFlags, EveryFlagReachesItsField) {
  const v1::GatherOptions o =
      parse({"--mb-res", "16", "--max-solid-angle", "0.01", "--ao-max-distance", "2",
             "--light-samples", "4", "--pixel-samples", "3", "--method", "fpbgi", "--clusters",
             "50", "--epsilon", "0.02", "--hdr-refine", "0.5", "--glossy-max-res", "64",
             "--glossy-importance", "0.05", "--glossy-radiance-weight", "0"});
  EXPECT_EQ(o.microbuffer_resolution(), 16u);
  EXPECT_FLOAT_EQ(o.max_solid_angle(), 0.01f);
  EXPECT_FLOAT_EQ(o.ao_max_distance(), 2.f);
  EXPECT_EQ(o.light_samples(), 4u);
  EXPECT_EQ(o.pixel_samples(), 3u);
  EXPECT_EQ(o.method(), v1::GatherOptions::FPBGI);
  EXPECT_EQ(o.clusters(), 50u);
  EXPECT_FLOAT_EQ(o.epsilon(), 0.02f);
  EXPECT_FLOAT_EQ(o.hdr_refine(), 0.5f);
  EXPECT_EQ(o.glossy_max_resolution(), 64u);
  EXPECT_FLOAT_EQ(o.glossy_importance(), 0.05f);
  ASSERT_TRUE(o.has_glossy_radiance_weight());
  EXPECT_EQ(o.glossy_radiance_weight(), 0.f);
  EXPECT_EQ(parse({"--method", "pbgi"}).method(), v1::GatherOptions::PBGI);
}

TEST(GatherFlags, UnknownMethodIsRefused) {
  EXPECT_THROW(parse({"--method", "radiosity"}), CLI::ValidationError);
}

}  // namespace
}  // namespace pbgi::cli
