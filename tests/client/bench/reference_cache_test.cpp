#include "client/bench/reference_cache.h"

#include "client/bench/scene_hash.h"
#include "tests/stability/stability_scenes.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <unistd.h>

namespace pbgi::bench {
namespace {

namespace fs = std::filesystem;

fs::path scratch(const std::string& name) {
  const fs::path dir = fs::path(PBGI_TEST_BINARY_DIR) / "bench-scratch" /
                       (name + "-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

TEST(SceneHash, ChangesWithWhatLightTransportReads) {
  const Scene a = stability::cornell_box();
  Scene b = a;
  EXPECT_EQ(scene_model_hash(a), scene_model_hash(b));
  b.source_path = "elsewhere";  // names do not matter
  b.cameras.clear();
  EXPECT_EQ(scene_model_hash(a), scene_model_hash(b));
  b.materials[0].albedo.x += 0.01f;
  EXPECT_NE(scene_model_hash(a), scene_model_hash(b));
  Scene c = a;
  c.triangles.positions[3].y += 1e-6f;
  EXPECT_NE(scene_model_hash(a), scene_model_hash(c));
  Scene d = a;
  d.lights[0].radiance *= 2.f;
  EXPECT_NE(scene_model_hash(a), scene_model_hash(d));
  // The specular inputs the reference's BRDF reads.
  Scene e = a;
  e.materials[0].ior = 1.4f;
  EXPECT_NE(scene_model_hash(a), scene_model_hash(e));
  Scene f = a;
  f.materials[0].use_specular_workflow = true;
  EXPECT_NE(scene_model_hash(a), scene_model_hash(f));
  Scene g = a;
  g.materials[0].specular_color.x = 0.5f;
  EXPECT_NE(scene_model_hash(a), scene_model_hash(g));
}

TEST(ReferenceCache, KeyCoversSizeSppDepthSeedAndCamera) {
  const Scene s = stability::cornell_box();
  const Camera& cam = s.cameras.at("/Camera");
  ReferenceOptions o;
  const std::string k = reference_cache_key("h", cam, o);
  EXPECT_EQ(k, reference_cache_key("h", cam, o));
  EXPECT_NE(k, reference_cache_key("g", cam, o));
  auto changed = [&](auto edit) {
    ReferenceOptions x = o;
    edit(x);
    return reference_cache_key("h", cam, x);
  };
  EXPECT_NE(k, changed([](ReferenceOptions& x) { x.width += 1; }));
  EXPECT_NE(k, changed([](ReferenceOptions& x) { x.spp *= 2; }));
  EXPECT_NE(k, changed([](ReferenceOptions& x) { x.max_depth = 2; }));
  EXPECT_NE(k, changed([](ReferenceOptions& x) { x.seed += 1; }));
  // Scheduling does not change the image, so not the key either.
  EXPECT_EQ(k, changed([](ReferenceOptions& x) { x.pass_spp = 1; x.tile_size = 32; }));
  Camera moved = cam;
  moved.local_to_world[3][0] += 0.1f;
  EXPECT_NE(k, reference_cache_key("h", moved, o));
}

TEST(ReferenceCache, RoundTripsAndRejectsMismatches) {
  const fs::path dir = scratch("refcache");
  ReferenceImage r;
  r.width = 3;
  r.height = 2;
  r.spp = 17;
  for (auto* layer : {&r.beauty, &r.direct, &r.indirect, &r.indirect1, &r.albedo}) {
    layer->resize(18);
    for (size_t i = 0; i < 18; ++i) (*layer)[i] = 0.1f * float(i) + float(layer - &r.beauty);
  }
  r.ao.assign(6, 0.5f);
  const fs::path file = reference_cache_file(dir, "0123456789abcdef");
  EXPECT_EQ(file.filename(), "reference-0123456789abcdef.exr");
  std::string warning;
  EXPECT_FALSE(load_cached_reference(file, "0123456789abcdef", 3, 2, &warning));
  EXPECT_TRUE(warning.empty());  // missing is not a problem

  store_cached_reference(file, "0123456789abcdef", r, 12.5, 20.25);
  auto back = load_cached_reference(file, "0123456789abcdef", 3, 2, &warning);
  ASSERT_TRUE(back);
  EXPECT_EQ(back->image.beauty, r.beauty);
  EXPECT_EQ(back->image.indirect, r.indirect);
  EXPECT_EQ(back->image.spp, 17u);
  EXPECT_DOUBLE_EQ(back->seconds, 12.5);
  EXPECT_DOUBLE_EQ(back->cpu_seconds, 20.25);

  // Another key or size under that name: not used, and said so.
  EXPECT_FALSE(load_cached_reference(file, "fedcba9876543210", 3, 2, &warning));
  EXPECT_NE(warning.find("does not match"), std::string::npos) << warning;
  warning.clear();
  EXPECT_FALSE(load_cached_reference(file, "0123456789abcdef", 2, 3, &warning));
  EXPECT_FALSE(warning.empty());
  // A truncated file: unreadable, re-rendered.
  std::ofstream(file, std::ios::trunc) << "not an exr";
  warning.clear();
  EXPECT_FALSE(load_cached_reference(file, "0123456789abcdef", 3, 2, &warning));
  EXPECT_NE(warning.find("unreadable"), std::string::npos) << warning;
  fs::remove_all(dir);
}

}  // namespace
}  // namespace pbgi::bench
