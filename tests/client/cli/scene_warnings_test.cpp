// Scene warnings reach the CLI user once each, summarised: warnings that
// differ only in their prim make one line, and a flood is cut with a count.
#include "client/cli/scene_warnings.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <string>
#include <vector>

namespace pbgi::cli {
namespace {

TEST(SceneWarnings, SameProblemOnManyPrimsIsOneLine) {
  const std::vector<std::string> warnings = {
      "/A: texture missing",  "the scene has no light", "/B: texture missing", "/C: texture missing",
      "/D: texture missing",  "/E: skinning is not applied", "/F: texture missing"};
  const std::vector<std::string> lines = summarize_scene_warnings(warnings);
  ASSERT_EQ(lines.size(), 3u);
  EXPECT_EQ(lines[0], "texture missing (5 prims: /A, /B, /C and 2 more)");
  EXPECT_EQ(lines[1], "the scene has no light");
  EXPECT_EQ(lines[2], "/E: skinning is not applied");
}

TEST(SceneWarnings, AFloodIsCutWithACount) {
  std::vector<std::string> warnings;
  for (int i = 0; i < 30; ++i) warnings.push_back("/P" + std::to_string(i) + ": problem " + std::to_string(i));
  const std::vector<std::string> lines = summarize_scene_warnings(warnings, 5);
  ASSERT_EQ(lines.size(), 5u);
  EXPECT_EQ(lines[3], "/P3: problem 3");
  EXPECT_EQ(lines[4], "26 more warnings (pbgi status --json lists them all)");
  EXPECT_EQ(summarize_scene_warnings(std::vector<std::string>(warnings.begin(), warnings.begin() + 5), 5).size(), 5u);
  EXPECT_TRUE(summarize_scene_warnings({}).empty());
}

TEST(SceneWarnings, PrintedWithTheirIndent) {
  v1::SceneInfo info;
  info.add_warnings("/A: x");
  info.add_warnings("/B: x");
  std::FILE* f = std::tmpfile();
  ASSERT_NE(f, nullptr);
  print_scene_warnings(info, f, "  ");
  std::rewind(f);
  char buf[256] = {};
  const size_t n = std::fread(buf, 1, sizeof buf - 1, f);
  std::fclose(f);
  EXPECT_EQ(std::string(buf, n), "  warning: x (2 prims: /A, /B)\n");
}

}  // namespace
}  // namespace pbgi::cli
