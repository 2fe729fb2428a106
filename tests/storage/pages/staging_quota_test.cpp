// The staging quota: what builds stage (sort runs, pages, manifest) is
// charged before it is written, released when a run is merged away and when
// the set is published or the build fails; a build that would pass the
// quota stops with ResourceExhausted naming it and leaves nothing behind.
#include "storage/pages/staging_quota.h"
#include "common/errors.h"
#include "storage/pages/page_set.h"
#include "storage/tree/tree_builder.h"
#include "tests/storage/pages/temp_dir.h"
#include "tests/storage/tree/random_surfels.h"

#include <gtest/gtest.h>

#include <memory>

namespace pbgi::storage {
namespace {

namespace fs = std::filesystem;

// Entries of `dir` (page sets and staging directories).
size_t entries(const fs::path& dir) {
  size_t n = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir)) ++n;
  return n;
}

// A build that spills sort runs (64 KiB of sort memory for 20 000 surfels).
tree::BuildOptions spilling() {
  tree::BuildOptions o;
  o.page_size = 16384;
  o.sort_memory_bytes = 64 * 1024;
  return o;
}

Manifest build(const std::vector<Surfel>& surfels, const fs::path& dir, std::shared_ptr<StagingQuota> quota,
               BuildReport* report = nullptr) {
  PageSetBuilder b(spilling(), "quota", dir, tree::surfel_bounds(surfels));
  b.set_staging_quota(std::move(quota));
  b.add(surfels);
  const Manifest m = b.finish();
  if (report) *report = b.report();
  return m;
}

TEST(StagingQuota, ChargesAndReleasesAgainstItsLimit) {
  auto quota = std::make_shared<StagingQuota>(1000);
  {
    StagingUsage a, b;
    a.set_quota(quota);
    b.set_quota(quota);
    a.charge(600, "a/run-000000.tmp");
    try {
      b.charge(401, "b/pages.pbgp");
      FAIL() << "1001 bytes fit a quota of 1000";
    } catch (const ResourceExhausted& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("staging_quota of 1000 bytes"), std::string::npos) << what;
      EXPECT_NE(what.find("b/pages.pbgp"), std::string::npos) << what;
    }
    EXPECT_EQ(b.held(), 0u) << "a refused charge holds nothing";
    b.charge(400, "b/pages.pbgp");
    EXPECT_EQ(quota->used(), 1000u);
    a.release(100);
    EXPECT_EQ(quota->used(), 900u);
  }
  EXPECT_EQ(quota->used(), 0u) << "destroyed usages release what they held";
}

TEST(StagingQuota, PublishedBuildReleasesWhatItStaged) {
  test::TempDir tmp;
  const std::vector<Surfel> surfels = test::random_surfels(20000, 5);
  auto quota = std::make_shared<StagingQuota>(uint64_t(1) << 30);
  BuildReport report;
  const Manifest m = build(surfels, tmp.path() / "set", quota, &report);
  EXPECT_GT(report.runs, 1u) << "the build staged sort runs";
  EXPECT_EQ(quota->used(), 0u) << "runs merged away, pages published: nothing staged any more";
  EXPECT_EQ(m.stats.surfel_count, surfels.size());
}

TEST(StagingQuota, BuildOverTheQuotaStopsAndLeavesNothing) {
  test::TempDir tmp;
  const std::vector<Surfel> surfels = test::random_surfels(20000, 5);
  // The sort runs (compressed, ~20 bytes a surfel) and the pages need more than this.
  auto quota = std::make_shared<StagingQuota>(512 * 1024);
  try {
    build(surfels, tmp.path() / "set", quota);
    FAIL() << "the build fit in " << quota->limit() << " bytes";
  } catch (const ResourceExhausted& e) {
    EXPECT_NE(std::string(e.what()).find("staging_quota of 524288 bytes"), std::string::npos) << e.what();
  }
  EXPECT_EQ(entries(tmp.path()), 0u) << "the staging directory was removed";
  EXPECT_EQ(quota->used(), 0u);

  // The same quota holds a build small enough for it.
  build(test::random_surfels(2000, 6), tmp.path() / "small", quota);
  EXPECT_TRUE(fs::exists(tmp.path() / "small" / kManifestFileName));
  EXPECT_EQ(quota->used(), 0u);
}

}  // namespace
}  // namespace pbgi::storage
