// Fog through the engine (scene_fog.h): opening a scene with a fog grid
// makes the grid the rays' medium (surfels under it are shaded through it)
// and gives the session lit volume points for the gathers; an empty grid
// is no fog.
#include "server/engine/scene_session.h"
#include "server/volumes/volume_grid.h"
#include "storage/cache/page_cache.h"
#include "tests/stability/stability_scenes.h"

#include <openvdb/openvdb.h>

#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <filesystem>

namespace pbgi {
namespace {

namespace fs = std::filesystem;

constexpr float kAlbedo = 0.5f;

// A 10 x 10 floor facing +y, the sun straight above, and a fog slab
// y in [0.95, 1.95], |x|, |z| < 2 of density `density` (0: an empty grid).
std::unique_ptr<Scene> foggy_floor(float density) {
  openvdb::initialize();
  stability::SceneBuilder b("engine-fog");
  const uint32_t m = b.material({kAlbedo, kAlbedo, kAlbedo});
  b.quad({-5, 0, -5}, {-5, 0, 5}, {5, 0, 5}, {5, 0, -5}, m, "/Floor");
  b.distant_light({0, -1, 0}, {2, 2, 2});
  auto scene = std::make_unique<Scene>(b.take());
  openvdb::FloatGrid::Ptr grid = openvdb::FloatGrid::create(0.f);
  grid->setTransform(openvdb::math::Transform::createLinearTransform(0.1));
  if (density > 0.f) grid->denseFill(openvdb::CoordBBox({-20, 10, -20}, {19, 19, 19}), density, true);
  Volume v;
  v.prim_path = "/Fog";
  v.kind = VolumeKind::Fog;
  v.voxel_size = 0.1f;
  v.grid = std::make_shared<VolumeGrid>(grid);
  if (density > 0.f) v.bounds = Box3f(V3f(-2.05f, 0.95f, -2.05f), V3f(1.95f, 1.95f, 1.95f));
  scene->volumes.push_back(v);
  return scene;
}

class EngineFog : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("pbgi-engine-fog-" + std::to_string(::getpid()) + "-" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    ctx_.cache_dir = dir_;
    ctx_.cache = std::make_shared<storage::PageCache>(256ull << 20);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::shared_ptr<SceneSession> open(float density) {
    OpenOptions o;
    o.surfels.target_surfels = 8000;
    return open_scene_model(foggy_floor(density), o, ctx_);
  }

  fs::path dir_;
  EngineContext ctx_;
};

TEST_F(EngineFog, SurfelsUnderTheSlabAreShadedThroughIt) {
  const auto s = open(0.6f);
  ASSERT_NE(s->fog, nullptr);
  EXPECT_FALSE(s->fog->empty());
  ASSERT_NE(s->rays->medium(), nullptr);
  EXPECT_NE(s->scene->content_hash.find("+fog/1"), std::string::npos);
  // Mean radiance of floor surfels under the slab and away from it.
  double under = 0, clear = 0;
  uint64_t n_under = 0, n_clear = 0;
  // Full surfels: the session's reader keeps in its pages only what
  // gathers read of them (gather::attach_view).
  const storage::PageSetReader pages(s->tree->directory(), nullptr);
  for (uint32_t id = 0; id < s->tree->manifest().stats.page_count; ++id) {
    // Held: nothing caches this reader's pages, and a range-for does not
    // keep a temporary's page alive while its surfels are read.
    const tree::PagePtr page = pages.page(id);
    for (const Surfel& surfel : page->surfels) {
      const V3f& p = surfel.position;
      if (std::fabs(p.x) < 1.5f && std::fabs(p.z) < 1.5f) {
        under += surfel.radiance.y;
        ++n_under;
      } else if (std::fabs(p.x) > 2.5f || std::fabs(p.z) > 2.5f) {
        clear += surfel.radiance.y;
        ++n_clear;
      }
    }
  }
  ASSERT_GT(n_under, 100u);
  ASSERT_GT(n_clear, 100u);
  EXPECT_NEAR(clear / n_clear, kAlbedo / M_PI * 2.0, 0.01);
  EXPECT_NEAR((under / n_under) / (clear / n_clear), std::exp(-0.6), 0.01);
}

TEST_F(EngineFog, AnEmptyGridIsNoFog) {
  const auto s = open(0.f);
  EXPECT_EQ(s->fog, nullptr);
  EXPECT_EQ(s->rays->medium(), nullptr);
  EXPECT_EQ(s->scene->content_hash.find("+fog"), std::string::npos);
}

}  // namespace
}  // namespace pbgi
