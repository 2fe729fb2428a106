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

// A daemon's engine context in a fresh cache directory, with a memory
// budget of 256 MiB (16 MiB for requests, a 16 MiB page cache floor).
class SceneSessionTest : public ::testing::Test {
 protected:
  void SetUp() override {
    fs::remove_all(dir_);
    ctx_.cache_dir = dir_;
    ctx_.cache = cache_;
    ctx_.memory = MemoryAccountant::create({256ull << 20, 16ull << 20, 16ull << 20}, cache_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  uint64_t charged(ChargeKind kind) const { return ctx_.memory->usage().charged[size_t(kind)]; }

  const fs::path dir_ = fs::temp_directory_path() / ("pbgi-scene-session-" + std::to_string(::getpid()));
  std::shared_ptr<storage::PageCache> cache_ = std::make_shared<storage::PageCache>(64ull << 20);
  EngineContext ctx_;
};

TEST_F(SceneSessionTest, ChargesGeometryRayStructureAndPageTable) {
  // The page table stays in memory while the scene is open (~2.25 bytes a
  // page, storage/pages/page_table.h); before it was charged, a billion
  // surfels held 1.15 GB of it beside the budget.
  OpenOptions o;
  o.surfels.target_surfels = 20000;
  {
    auto s = open_scene_model(std::make_unique<Scene>(stability::cornell_box()), o, ctx_);
    const uint64_t table = s->tree->manifest().pages.memory_bytes();
    EXPECT_GT(table, 0u);
    EXPECT_EQ(charged(ChargeKind::kScene), s->scene->geometry_bytes() + s->rays->memory_bytes() + table);
    EXPECT_EQ(charged(ChargeKind::kBuild), 0u);
  }
  EXPECT_EQ(ctx_.memory->usage().charged_total(), 0u);
}

// A build's page table grows with its pages and is charged as it grows
// (PageSetBuilder::set_memory_hook), beside the build's estimate: at the
// end of the tree stage the build's charge holds the table. Before, the
// build's charge stayed at its estimate (0.16 GB uncharged at 1 G surfels).
TEST_F(SceneSessionTest, BuildChargesItsGrowingPageTable) {
  OpenOptions o;
  o.surfels.target_surfels = 20000;
  uint64_t first = 0, last = 0;  // the build's charge when the tree stage starts and ends
  bool started = false;
  auto progress = [&](const std::string& stage, float) {
    if (stage != "tree") return;
    const uint64_t build = charged(ChargeKind::kBuild);
    if (!started) first = build;
    started = true;
    last = build;
  };
  {
    auto s = open_scene_model(std::make_unique<Scene>(stability::cornell_box()), o, ctx_, progress);
    ASSERT_TRUE(started);
    EXPECT_GT(first, 0u);  // the estimate
    EXPECT_GE(last - first, storage::PageTable::bytes_for(s->tree->manifest().stats.page_count));
    EXPECT_EQ(charged(ChargeKind::kBuild), 0u);
  }
  EXPECT_EQ(ctx_.memory->usage().charged_total(), 0u);
}

// A bounce's build holds its own table, its reader's copy of the direct
// set's and the direct set's reader's: all three are charged while it
// writes its pages.
TEST_F(SceneSessionTest, BounceBuildChargesTheTablesItHolds) {
  OpenOptions o;
  o.surfels.target_surfels = 5000;
  o.bounce.bounces = 2;
  uint64_t estimate = 0, last = 0;
  auto progress = [&](const std::string& stage, float) {
    const uint64_t build = charged(ChargeKind::kBuild);
    if (stage == "tree" && estimate == 0) estimate = build;
    if (stage == "bounce 2") last = build;
  };
  {
    auto s = open_scene_model(std::make_unique<Scene>(stability::cornell_box()), o, ctx_, progress);
    ASSERT_GT(estimate, 0u);
    // Two copies of the direct set's table (its reader's, the bounce
    // gather's reader's) and the bounce set's own, of as many pages.
    EXPECT_GE(last - estimate, 3 * storage::PageTable::bytes_for(s->tree->manifest().stats.page_count))
        << "charged " << last << ", estimate " << estimate;
    EXPECT_EQ(charged(ChargeKind::kBuild), 0u);
  }
  EXPECT_EQ(ctx_.memory->usage().charged_total(), 0u);
}

}  // namespace
}  // namespace pbgi
