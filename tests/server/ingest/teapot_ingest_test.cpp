// Every USD file of the USD Working Group's Teapot asset (payloads,
// variants, GeomSubsets, catmullClark cages, textured materials) reads
// without error and yields triangles. Skipped where /work/shared is absent.
#include "server/ingest/usd_ingest.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>

namespace pbgi {
namespace {

namespace fs = std::filesystem;

const fs::path kTeapotDir = "/work/shared/scenes/usd-wg/full_assets/Teapot";

std::vector<std::string> teapot_files() {
  std::vector<std::string> files;
  std::error_code ec;
  if (!fs::is_directory(kTeapotDir, ec)) return files;
  for (const auto& entry : fs::recursive_directory_iterator(kTeapotDir, ec)) {
    const std::string ext = entry.path().extension().string();
    if (entry.is_regular_file() && (ext == ".usd" || ext == ".usda"))
      files.push_back(fs::relative(entry.path(), kTeapotDir).string());
  }
  std::sort(files.begin(), files.end());
  return files;
}

class TeapotFile : public ::testing::TestWithParam<std::string> {};

TEST_P(TeapotFile, ReadsWithTriangles) {
  const Scene scene = read_usd_scene(kTeapotDir / GetParam(), IngestOptions{});
  EXPECT_GT(scene.triangles.triangle_count(), 0u);
  EXPECT_FALSE(scene.materials.empty());
  EXPECT_EQ(scene.up_axis, "Y");
  // The teapots are catmullClark cages, refined without complaint.
  for (const std::string& w : scene.warnings) EXPECT_EQ(w.find("subdivision"), std::string::npos) << w;
}

INSTANTIATE_TEST_SUITE_P(UsdWg, TeapotFile, ::testing::ValuesIn(teapot_files()),
                         [](const ::testing::TestParamInfo<std::string>& info) {
                           std::string name = info.param;
                           for (char& c : name)
                             if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                           return name;
                         });
GTEST_ALLOW_UNINSTANTIATED_PARAMETERIZED_TEST(TeapotFile);

TEST(TeapotAsset, IsPresent) {
  if (!fs::is_directory(kTeapotDir)) GTEST_SKIP() << kTeapotDir << " is absent";
  const auto files = teapot_files();
  EXPECT_NE(std::find(files.begin(), files.end(), "Teapot.usd"), files.end());
}

}  // namespace
}  // namespace pbgi
