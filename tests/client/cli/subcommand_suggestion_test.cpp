// A typo'd subcommand gets the one that was meant; nonsense gets none.
#include "client/cli/subcommand_suggestion.h"

#include <gtest/gtest.h>

namespace pbgi::cli {
namespace {

const std::vector<std::string> kNames = {"bench", "compare", "health", "inspect", "reference",
                                         "render", "status", "stress", "tile"};

TEST(SubcommandSuggestion, TyposFindTheSubcommand) {
  EXPECT_EQ(suggest_subcommand("rendr", kNames), "render");
  EXPECT_EQ(suggest_subcommand("redner", kNames), "render");  // swapped letters
  EXPECT_EQ(suggest_subcommand("stauts", kNames), "status");
  EXPECT_EQ(suggest_subcommand("tiel", kNames), "tile");
  EXPECT_EQ(suggest_subcommand("ref", kNames), "reference");  // a prefix
  EXPECT_EQ(suggest_subcommand("benchmark", kNames), "");   // too far from "bench"
  EXPECT_EQ(suggest_subcommand("xyzzy", kNames), "");
}

}  // namespace
}  // namespace pbgi::cli
