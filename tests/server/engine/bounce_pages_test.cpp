// Multiple bounces through the engine: the page sets of bounces 2..n are
// gathered out of core from the direct set (server/engine/bounce_pages.h).
// A white furnace gives the exact answer: inside a closed box whose walls
// all emit Le and reflect a fraction a, the radiance after n bounces is
// Le (1 + a + ... + a^(n-1)), everywhere.
#include "common/errors.h"
#include "server/engine/scene_session.h"
#include "storage/cache/page_cache.h"
#include "tests/stability/stability_scenes.h"

#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <memory>

namespace pbgi {
namespace {

namespace fs = std::filesystem;
using stability::SceneBuilder;

constexpr float kLe = 1.f;
constexpr float kAlbedo = 0.5f;

// A 2-unit box whose six walls face inward, all emitting kLe.
std::unique_ptr<Scene> furnace() {
  SceneBuilder b("engine-furnace");
  const uint32_t m = b.material({kAlbedo, kAlbedo, kAlbedo}, {kLe, kLe, kLe});
  const float h = 1.f;
  b.quad({-h, -h, -h}, {-h, -h, h}, {h, -h, h}, {h, -h, -h}, m, "/Floor");
  b.quad({-h, h, -h}, {h, h, -h}, {h, h, h}, {-h, h, h}, m, "/Ceiling");
  b.quad({-h, -h, -h}, {-h, h, -h}, {-h, h, h}, {-h, -h, h}, m, "/Left");
  b.quad({h, -h, -h}, {h, -h, h}, {h, h, h}, {h, h, -h}, m, "/Right");
  b.quad({-h, -h, -h}, {h, -h, -h}, {h, h, -h}, {-h, h, -h}, m, "/Back");
  b.quad({-h, -h, h}, {-h, h, h}, {h, h, h}, {h, -h, h}, m, "/Front");
  return std::make_unique<Scene>(b.take());
}

// Mean outgoing radiance (green) over every surfel of the session's tree,
// read page by page.
double mean_radiance(const SceneSession& s) {
  double sum = 0;
  uint64_t n = 0;
  // Full surfels: the session's reader keeps in its pages only what
  // gathers read of them (gather::attach_view).
  const storage::PageSetReader pages(s.tree->directory(), nullptr);
  for (uint32_t id = 0; id < s.tree->manifest().stats.page_count; ++id) {
    // Held: nothing caches this reader's pages, and a range-for does not
    // keep a temporary's page alive while its surfels are read.
    const tree::PagePtr page = pages.page(id);
    for (const Surfel& surfel : page->surfels) {
      sum += surfel.radiance.y;
      ++n;
    }
  }
  return n ? sum / double(n) : 0.0;
}

class EngineBounces : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("pbgi-engine-bounce-" + std::to_string(::getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    ctx_.cache_dir = dir_;
    ctx_.cache = std::make_shared<storage::PageCache>(256ull << 20);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::shared_ptr<SceneSession> open(uint32_t bounces) {
    OpenOptions o;
    o.surfels.target_surfels = 6000;
    o.bounce.bounces = bounces;
    return open_scene_model(furnace(), o, ctx_);
  }

  fs::path dir_;
  EngineContext ctx_;
};

TEST_F(EngineBounces, FurnaceRadianceGrowsAsTheGeometricSeries) {
  const auto one = open(1);
  const auto three = open(3);
  // Bounce 1 is the emission alone (no lights: direct = Le).
  EXPECT_NEAR(mean_radiance(*one), kLe, 0.01 * kLe);
  const double want3 = kLe * (1 + kAlbedo + kAlbedo * kAlbedo);
  std::printf("[ measured ] furnace radiance: 1 bounce %.4f, 3 bounces %.4f (exact %.4f)\n",
              mean_radiance(*one), mean_radiance(*three), want3);
  EXPECT_NEAR(mean_radiance(*three), want3, 0.05 * want3);
  EXPECT_NE(one->info.scene_id, three->info.scene_id);
  EXPECT_EQ(three->info.tree.surfel_count, one->info.tree.surfel_count);
}

TEST_F(EngineBounces, IntermediateBouncesAreContentAddressedAndReused) {
  const auto three = open(3);
  EXPECT_FALSE(three->info.reused_cache);
  // The 3-bounce build left the sets of 1 and 2 bounces behind.
  const auto two = open(2);
  EXPECT_TRUE(two->info.reused_cache);
  const double want2 = kLe * (1 + kAlbedo);
  EXPECT_NEAR(mean_radiance(*two), want2, 0.05 * want2);
  const auto again = open(3);
  EXPECT_TRUE(again->info.reused_cache);
  EXPECT_EQ(again->info.scene_id, three->info.scene_id);
  EXPECT_EQ(mean_radiance(*again), mean_radiance(*three));
}

TEST_F(EngineBounces, BounceCountOutOfRangeIsRefused) {
  OpenOptions o;
  o.bounce.bounces = 0;
  EXPECT_THROW(open_scene_model(furnace(), o, ctx_), InvalidArgument);
  o.bounce.bounces = kMaxBounces + 1;
  EXPECT_THROW(open_scene_model(furnace(), o, ctx_), InvalidArgument);
}

}  // namespace
}  // namespace pbgi
