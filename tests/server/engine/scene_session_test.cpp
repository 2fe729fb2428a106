// What an open scene is charged to the daemon's memory budget.
#include "server/engine/scene_session.h"
#include "server/engine/memory_accountant.h"
#include "storage/cache/page_cache.h"
#include "tests/stability/stability_scenes.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <memory>

namespace pbgi {
namespace {

namespace fs = std::filesystem;

TEST(SceneSession, ChargesGeometryRayStructureAndPageTable) {
  // The page table stays in memory while the scene is open (~2.25 bytes a
  // page, storage/pages/page_table.h); before it was charged, a billion
  // surfels held 1.15 GB of it beside the budget.
  const fs::path dir = fs::temp_directory_path() / ("pbgi-scene-session-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  auto cache = std::make_shared<storage::PageCache>(64ull << 20);
  EngineContext ctx;
  ctx.cache_dir = dir;
  ctx.cache = cache;
  ctx.memory = MemoryAccountant::create({256ull << 20, 16ull << 20, 16ull << 20}, cache);
  OpenOptions o;
  o.surfels.target_surfels = 20000;
  {
    auto s = open_scene_model(std::make_unique<Scene>(stability::cornell_box()), o, ctx);
    const uint64_t table = s->tree->manifest().pages.memory_bytes();
    EXPECT_GT(table, 0u);
    EXPECT_EQ(ctx.memory->usage().charged[size_t(ChargeKind::kScene)],
              s->scene->geometry_bytes() + s->rays->memory_bytes() + table);
    EXPECT_EQ(ctx.memory->usage().charged[size_t(ChargeKind::kBuild)], 0u);
  }
  EXPECT_EQ(ctx.memory->usage().charged_total(), 0u);
  fs::remove_all(dir);
}

// A build's page table grows with its pages and is charged as it grows
// (PageSetBuilder::set_memory_hook), beside the build's estimate: at the
// end of the tree stage the build's charge holds the table. Before, the
// build's charge stayed at its estimate (0.16 GB uncharged at 1 G surfels).
TEST(SceneSession, BuildChargesItsGrowingPageTable) {
  const fs::path dir = fs::temp_directory_path() / ("pbgi-scene-session-build-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  auto cache = std::make_shared<storage::PageCache>(64ull << 20);
  EngineContext ctx;
  ctx.cache_dir = dir;
  ctx.cache = cache;
  ctx.memory = MemoryAccountant::create({256ull << 20, 16ull << 20, 16ull << 20}, cache);
  OpenOptions o;
  o.surfels.target_surfels = 20000;
  uint64_t first = 0, last = 0;  // the build's charge when the tree stage starts and ends
  bool started = false;
  auto progress = [&](const std::string& stage, float) {
    if (stage != "tree") return;
    const uint64_t build = ctx.memory->usage().charged[size_t(ChargeKind::kBuild)];
    if (!started) first = build;
    started = true;
    last = build;
  };
  {
    auto s = open_scene_model(std::make_unique<Scene>(stability::cornell_box()), o, ctx, progress);
    ASSERT_TRUE(started);
    EXPECT_GT(first, 0u);  // the estimate
    EXPECT_GE(last - first, storage::PageTable::bytes_for(s->tree->manifest().stats.page_count));
    EXPECT_EQ(ctx.memory->usage().charged[size_t(ChargeKind::kBuild)], 0u);
  }
  EXPECT_EQ(ctx.memory->usage().charged_total(), 0u);
  fs::remove_all(dir);
}

// A bounce's build holds its own table, its reader's copy of the direct
// set's and the direct set's reader's: all three are charged while it
// writes its pages.
TEST(SceneSession, BounceBuildChargesTheTablesItHolds) {
  const fs::path dir = fs::temp_directory_path() / ("pbgi-scene-session-bounce-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  auto cache = std::make_shared<storage::PageCache>(64ull << 20);
  EngineContext ctx;
  ctx.cache_dir = dir;
  ctx.cache = cache;
  ctx.memory = MemoryAccountant::create({256ull << 20, 16ull << 20, 16ull << 20}, cache);
  OpenOptions o;
  o.surfels.target_surfels = 5000;
  o.bounce.bounces = 2;
  uint64_t estimate = 0, last = 0;
  auto progress = [&](const std::string& stage, float) {
    const uint64_t build = ctx.memory->usage().charged[size_t(ChargeKind::kBuild)];
    if (stage == "tree" && estimate == 0) estimate = build;
    if (stage == "bounce 2") last = build;
  };
  {
    auto s = open_scene_model(std::make_unique<Scene>(stability::cornell_box()), o, ctx, progress);
    ASSERT_GT(estimate, 0u);
    // Two copies of the direct set's table (its reader's, the bounce
    // gather's reader's) and the bounce set's own, of as many pages.
    EXPECT_GE(last - estimate, 3 * storage::PageTable::bytes_for(s->tree->manifest().stats.page_count))
        << "charged " << last << ", estimate " << estimate;
    EXPECT_EQ(ctx.memory->usage().charged[size_t(ChargeKind::kBuild)], 0u);
  }
  EXPECT_EQ(ctx.memory->usage().charged_total(), 0u);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace pbgi
