// --variant and --time-code parse into the OpenSceneRequest; a malformed
// --variant is refused by name before anything is sent.
#include "client/cli/scene_flags.h"
#include "tests/client/cli/parse_flags.h"

#include "common/errors.h"

#include <gtest/gtest.h>

namespace pbgi::cli {
namespace {

SceneArgs parse(std::vector<std::string> argv) { return testing::parse_flags<SceneArgs>(std::move(argv)); }

TEST(SceneFlags, VariantsAndTimeCodeFillTheRequest) {
  const v1::OpenSceneRequest r =
      parse({"--variant", "/Car:color=red", "--variant", "/Car/Trim:style=chrome", "--time-code", "12.5"})
          .request("/s.usda", v1::BuildOptions());
  EXPECT_EQ(r.scene_path(), "/s.usda");
  ASSERT_EQ(r.variant_selections_size(), 2);
  EXPECT_EQ(r.variant_selections().at("/Car:color"), "red");
  EXPECT_EQ(r.variant_selections().at("/Car/Trim:style"), "chrome");
  ASSERT_TRUE(r.has_time_code());
  EXPECT_EQ(r.time_code(), 12.5);
  EXPECT_FALSE(parse({}).request("/s.usda", v1::BuildOptions()).has_time_code());
  // 0 is a time like any other, not "unset".
  EXPECT_TRUE(parse({"--time-code", "0"}).request("/s.usda", v1::BuildOptions()).has_time_code());
}

TEST(SceneFlags, MalformedVariantsAreRefusedByName) {
  for (const char* bad : {"Car:color=red", "/Car=red", "/Car:color", "/Car:=red", "/Car:color=", ":color=red"}) {
    try {
      parse({"--variant", bad}).request("/s.usda", v1::BuildOptions());
      ADD_FAILURE() << bad;
    } catch (const InvalidArgument& e) {
      EXPECT_NE(std::string(e.what()).find(std::string("--variant '") + bad + "'"), std::string::npos) << e.what();
    }
  }
  EXPECT_THROW(parse({"--variant", "/Car:color=red", "--variant", "/Car:color=blue"})
                   .request("/s.usda", v1::BuildOptions()),
               InvalidArgument);
}

}  // namespace
}  // namespace pbgi::cli
