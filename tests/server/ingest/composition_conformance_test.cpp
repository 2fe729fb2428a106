// Composition conformance against the USD working group's assets
// (/work/shared/scenes/usd-wg, skipped where absent):
//
// - every test_assets/foundation case: the render prims read_usd_scene
//   produces (TriangleSoup::mesh_paths) and their world-space bounds equal
//   what USD composition specifies, as computed at test time by pxr
//   (expected_render_prims.py: UsdGeom.BBoxCache over the default/render
//   purpose gprims that are active and visible);
// - every other scene of the collection (full_assets) opens without crash
//   (or fails with a SceneError naming it); what the reader skipped or
//   repaired is printed.
#include "server/ingest/usd_ingest.h"

#include "common/errors.h"
#include "pbgi_build_config.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <iostream>
#include <map>
#include <optional>
#include <set>
#include <sstream>

namespace pbgi {
namespace {

namespace fs = std::filesystem;

const fs::path kUsdWg = (fs::path(PBGI_TEST_SOURCE_DIR) / ".." / "shared" / "scenes" / "usd-wg").lexically_normal();

bool is_usd(const fs::path& p) {
  const std::string e = p.extension().string();
  return e == ".usd" || e == ".usda" || e == ".usdc" || e == ".usdz";
}

// Scene files under `dir` relative to it, sorted (empty if it is absent).
std::vector<std::string> scenes_under(const fs::path& dir) {
  std::vector<std::string> out;
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return out;
  for (const auto& e : fs::recursive_directory_iterator(dir, ec))
    if (e.is_regular_file() && is_usd(e.path())) out.push_back(fs::relative(e.path(), dir).string());
  std::sort(out.begin(), out.end());
  return out;
}

struct ExpectedPrim {
  std::string type;
  Box3f bounds;
};

// Runs the pxr oracle; nullopt if it could not open the stage.
std::optional<std::map<std::string, ExpectedPrim>> expected_render_prims(const fs::path& scene) {
  const fs::path script = fs::path(PBGI_TEST_SOURCE_DIR) / "tests/server/ingest/expected_render_prims.py";
  const std::string command = std::string("'") + PBGI_PYTHON + "' -B '" + script.string() + "' '" + scene.string() +
                              "' 2>/dev/null";
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) return std::nullopt;
  std::string text;
  char buffer[4096];
  while (size_t n = fread(buffer, 1, sizeof buffer, pipe)) text.append(buffer, n);
  if (pclose(pipe) != 0) return std::nullopt;
  std::map<std::string, ExpectedPrim> out;
  std::istringstream lines(text);
  std::string line;
  while (std::getline(lines, line)) {
    std::istringstream fields(line);
    std::string type, path;
    std::getline(fields, type, '\t');
    std::getline(fields, path, '\t');
    ExpectedPrim e{type, {}};
    fields >> e.bounds.min.x >> e.bounds.min.y >> e.bounds.min.z >> e.bounds.max.x >> e.bounds.max.y >> e.bounds.max.z;
    out[path] = e;
  }
  return out;
}

bool is_modelled(const std::string& type) {
  static const std::set<std::string> kModelled = {"Mesh",   "Cube",      "Sphere", "Cylinder", "Cylinder_1",
                                                  "Cone",   "Capsule",   "Capsule_1", "Plane"};
  return kModelled.count(type) > 0;
}

std::map<std::string, Box3f> mesh_bounds(const Scene& scene) {
  std::map<std::string, Box3f> out;
  const TriangleSoup& t = scene.triangles;
  for (size_t i = 0; i < t.indices.size(); ++i) out[t.mesh_paths[t.mesh[i / 3]]].extendBy(t.positions[t.indices[i]]);
  return out;
}

class FoundationCase : public ::testing::TestWithParam<std::string> {};

TEST_P(FoundationCase, RenderPrimsAndBoundsMatchUsdComposition) {
  const fs::path scene_path = kUsdWg / "test_assets/foundation" / GetParam();
  const auto expected = expected_render_prims(scene_path);
  if (!expected) {
    // USD itself cannot open it: the reader must say so, naming the file.
    EXPECT_THROW(read_usd_scene(scene_path, IngestOptions{}), SceneError);
    return;
  }
  // Flattened: the bounds are compared per instance proxy path, which
  // instanced geometry does not keep (instancing_ingest_test.cpp compares
  // instanced against flattened reads).
  IngestOptions flat;
  flat.flatten_instances = true;
  const Scene scene = read_usd_scene(scene_path, flat);
  const auto got = mesh_bounds(scene);

  for (const auto& [path, prim] : *expected) {
    if (!is_modelled(prim.type)) {
      const bool reported = std::any_of(scene.warnings.begin(), scene.warnings.end(),
                                        [&](const std::string& w) { return w.rfind(path + ": ", 0) == 0; });
      EXPECT_TRUE(reported) << prim.type << " " << path << " neither read nor reported";
      continue;
    }
    const auto it = got.find(path);
    ASSERT_NE(it, got.end()) << "render prim " << path << " (" << prim.type << ") missing";
    const V3f size = prim.bounds.size();
    // Tessellated curved implicits lie inside their analytic bounds, within
    // the tessellation's chord error; flat geometry matches to float error.
    const bool curved = prim.type != "Mesh" && prim.type != "Cube" && prim.type != "Plane";
    const float tolerance = (curved ? 0.02f : 1e-5f) * std::max({size.x, size.y, size.z, 1e-3f}) + 1e-5f;
    for (int k = 0; k < 3; ++k) {
      EXPECT_NEAR(it->second.min[k], prim.bounds.min[k], tolerance) << path << " axis " << k;
      EXPECT_NEAR(it->second.max[k], prim.bounds.max[k], tolerance) << path << " axis " << k;
    }
  }
  for (const auto& [path, box] : got)
    EXPECT_TRUE(expected->count(path)) << path << " was read but is not a render prim of the composed stage";
}

std::string test_name(const ::testing::TestParamInfo<std::string>& info) {
  std::string name = info.param;
  for (char& c : name)
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  return name;
}

INSTANTIATE_TEST_SUITE_P(UsdWg, FoundationCase, ::testing::ValuesIn(scenes_under(kUsdWg / "test_assets/foundation")),
                         test_name);
GTEST_ALLOW_UNINSTANTIATED_PARAMETERIZED_TEST(FoundationCase);

class UsdWgScene : public ::testing::TestWithParam<std::string> {};

// The foundation cases are opened by FoundationCase already.
TEST_P(UsdWgScene, OpensWithoutCrash) {
  const fs::path scene_path = kUsdWg / "full_assets" / GetParam();
  try {
    const Scene scene = read_usd_scene(scene_path, IngestOptions{});
    std::cout << GetParam() << ": " << scene.triangles.triangle_count() << " triangles, "
              << scene.triangles.mesh_paths.size() << " meshes, " << scene.lights.size() << " lights, "
              << scene.cameras.size() << " cameras, " << scene.warnings.size() << " warnings\n";
    for (const std::string& w : scene.warnings) std::cout << "  skipped/repaired: " << w << "\n";
  } catch (const SceneError& e) {
    // Allowed (e.g. a layer meant only to be referenced), but it must name the file.
    EXPECT_NE(std::string(e.what()).find(scene_path.filename().string()), std::string::npos) << e.what();
    std::cout << GetParam() << ": not opened: " << e.what() << "\n";
  }
}

INSTANTIATE_TEST_SUITE_P(UsdWg, UsdWgScene, ::testing::ValuesIn(scenes_under(kUsdWg / "full_assets")), test_name);
GTEST_ALLOW_UNINSTANTIATED_PARAMETERIZED_TEST(UsdWgScene);

}  // namespace
}  // namespace pbgi
