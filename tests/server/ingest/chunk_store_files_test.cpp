// The chunk store's files hold whole ingested scenes: its directory is
// 0700 and its entries 0600 whatever the umask, and the temporaries of a
// daemon that crashed while writing are removed when a store opens.
#include "server/ingest/chunk_store.h"
#include "tests/server/service/temp_dir.h"
#include "tests/storage/pages/dead_process.h"

#include <gtest/gtest.h>

#include <sys/stat.h>

#include <filesystem>
#include <fstream>

namespace pbgi {
namespace {

namespace fs = std::filesystem;

class ChunkStoreFiles : public ::testing::Test {
 protected:
  testing::TempDir tmp;
  const fs::path base = tmp.path();
};

TEST_F(ChunkStoreFiles, DirectoryAndEntriesArePrivateWhateverTheUmask) {
  ChunkStoreOptions options;
  options.directory = base / "cache" / "ingested";
  const mode_t previous = ::umask(022);
  const ChunkStore store(options);
  Scene scene;
  scene.content_hash = "test";
  store.save("0123456789abcdef0123456789abcdef", scene);
  ::umask(previous);
  EXPECT_EQ(fs::status(options.directory).permissions(), fs::perms::owner_all);
  size_t entries = 0;
  for (const fs::directory_entry& e : fs::directory_iterator(options.directory)) {
    ++entries;
    EXPECT_EQ(e.status().permissions(), fs::perms::owner_read | fs::perms::owner_write) << e.path();
  }
  EXPECT_EQ(entries, 1u) << "one entry (its dependencies are inside it)";
}

TEST_F(ChunkStoreFiles, TemporariesOfDeadWritersAreRemovedWhenTheStoreOpens) {
  const pid_t dead = testing::dead_process_id();
  const fs::path dir = base / "ingested";
  fs::create_directories(dir);
  const fs::path stale = dir / ("k.pbgiscene.tmp-" + std::to_string(dead) + "-1234567890");
  const fs::path live = dir / "k.pbgiscene.tmp-1-1234567890";  // pid 1 runs
  const fs::path entry = dir / "k.pbgiscene";
  for (const fs::path& p : {stale, live, entry}) std::ofstream(p) << "x";
  ChunkStoreOptions options;
  options.directory = dir;
  const ChunkStore store(options);
  EXPECT_FALSE(fs::exists(stale));
  EXPECT_TRUE(fs::exists(live));
  EXPECT_TRUE(fs::exists(entry));
}

}  // namespace
}  // namespace pbgi
