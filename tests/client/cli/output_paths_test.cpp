// Output paths are checked before a render or reference starts: a missing
// directory or a directory given as the file fails at once, with a reason.
#include "client/cli/output_paths.h"

#include "common/errors.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>

namespace pbgi::cli {
namespace {

namespace fs = std::filesystem;

std::string refusal(const std::string& path) {
  try {
    check_output_file(path, "--out");
  } catch (const InvalidArgument& e) {
    return e.what();
  }
  return "";
}

TEST(OutputPaths, AMissingDirectoryOrADirectoryIsRefusedWithTheReason) {
  const fs::path dir = fs::temp_directory_path() / ("pbgi-output-paths-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string missing = refusal((dir / "no-such-dir" / "render.exr").string());
  EXPECT_NE(missing.find("--out"), std::string::npos) << missing;
  EXPECT_NE(missing.find("does not exist"), std::string::npos) << missing;
  const std::string directory = refusal(dir.string());
  EXPECT_NE(directory.find("is a directory"), std::string::npos) << directory;
  EXPECT_NE(refusal(""), "");
  EXPECT_EQ(refusal((dir / "render.exr").string()), "");
  EXPECT_EQ(refusal("render.exr"), "") << "the working directory";
  fs::remove_all(dir);
}

}  // namespace
}  // namespace pbgi::cli
