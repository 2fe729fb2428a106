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

}  // namespace
}  // namespace pbgi
