// The engine's cache directory: page sets hold whole scenes, so everything
// a build writes is private to the daemon's user whatever the umask
// (storage/pages/cache_files.h), and what crashed runs left behind is
// removed by clean_cache_directory (server/engine/cache_cleanup.h).
#include "server/engine/cache_cleanup.h"
#include "server/engine/scene_session.h"
#include "storage/cache/page_cache.h"
#include "tests/server/service/temp_dir.h"
#include "tests/stability/stability_scenes.h"
#include "tests/storage/pages/dead_process.h"

#include <gtest/gtest.h>

#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <memory>

namespace pbgi {
namespace {

namespace fs = std::filesystem;

class EngineCacheFiles : public ::testing::Test {
 protected:
  testing::TempDir tmp_;
  const fs::path dir_ = tmp_.path();
};

std::unique_ptr<Scene> floor_and_light() {
  stability::SceneBuilder b("engine-cache-files");
  const uint32_t lit = b.material({0.5f, 0.5f, 0.5f}, {1.f, 1.f, 1.f});
  b.quad({-1, 0, -1}, {-1, 0, 1}, {1, 0, 1}, {1, 0, -1}, lit, "/Floor");
  return std::make_unique<Scene>(b.take());
}

TEST_F(EngineCacheFiles, PageSetFilesAre0600AndDirectories0700WhateverTheUmask) {
  EngineContext ctx;
  ctx.cache_dir = dir_ / "cache";
  ctx.cache = std::make_shared<storage::PageCache>(64ull << 20);
  OpenOptions o;
  o.surfels.target_surfels = 2000;
  const mode_t previous = ::umask(022);  // what a daemon usually inherits
  auto session = open_scene_model(floor_and_light(), o, ctx);
  ::umask(previous);
  ASSERT_TRUE(session->tree);

  size_t files = 0;
  EXPECT_EQ(fs::status(ctx.cache_dir).permissions(), fs::perms::owner_all);
  for (const fs::directory_entry& e : fs::recursive_directory_iterator(ctx.cache_dir)) {
    const fs::perms mode = e.status().permissions();
    if (e.is_directory()) {
      EXPECT_EQ(mode, fs::perms::owner_all) << e.path();
    } else {
      ++files;
      EXPECT_EQ(mode, fs::perms::owner_read | fs::perms::owner_write) << e.path();
    }
  }
  EXPECT_GT(files, 1u);
}

TEST_F(EngineCacheFiles, CleaningRemovesDeadBuildsAndCorruptSetsOnly) {
  const pid_t dead = testing::dead_process_id();
  const fs::path staging = dir_ / ("aa.tmp-" + std::to_string(dead) + "-0123456789abcdef");
  const fs::path corrupt = dir_ / ("bb" + std::string(kCorruptPageSetSuffix) + "123");
  const fs::path live = dir_ / "cc.tmp-1-0123456789abcdef";
  const fs::path page_set = dir_ / "dd";
  for (const fs::path& d : {staging, corrupt, live, page_set}) {
    fs::create_directories(d);
    std::ofstream(d / "manifest.pbgm") << "x";
  }
  EXPECT_EQ(clean_cache_directory(dir_), 2u);
  EXPECT_FALSE(fs::exists(staging));
  EXPECT_FALSE(fs::exists(corrupt));
  EXPECT_TRUE(fs::exists(live));
  EXPECT_TRUE(fs::exists(page_set / "manifest.pbgm"));
}

}  // namespace
}  // namespace pbgi
