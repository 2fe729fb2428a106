// Page sets of formats V6 and V7 (kPageSetFormatVersion 5, no longer
// written) still read, exactly as the build that wrote them read them.
//
// The sets in data/v6/ were written by main at 5aa8196 from
// test::random_surfels(400, 21) with default build options but page_size
// 4096: "derived" (V6 pages, payload_codec derived) and "stored" (V7,
// float32-sh). That build's reader, and its in-memory tree of the same
// surfels, gave the walk digest kDigest (walk_digest.h) for both.
#include "storage/pages/page_set.h"
#include "storage/pages/page_set_inspection.h"
#include "storage/tree/memory_tree.h"
#include "storage/tree/tree_builder.h"
#include "tests/storage/pages/walk_digest.h"
#include "tests/storage/tree/random_surfels.h"

#include <gtest/gtest.h>

#include <filesystem>

namespace pbgi::storage {
namespace {

constexpr uint64_t kDigest = 0x42a388729c4aef31;

TEST(V6PageSet, ReadsAsTheBuildThatWroteItRead) {
  const std::filesystem::path data = std::filesystem::path(PBGI_TEST_SOURCE_DIR) / "tests/storage/pages/data/v6";
  const std::vector<Surfel> surfels = test::random_surfels(400, 21);
  tree::BuildOptions o;
  o.page_size = 4096;
  const tree::MemoryTree today(tree::build_tree(surfels, o));
  for (const auto& [name, format] : {std::pair{"derived", kPageFormatV6}, std::pair{"stored", kPageFormatV7}}) {
    const PageSetReader reader(data / name, nullptr);
    EXPECT_EQ(reader.manifest().page_format, format) << name;
    EXPECT_EQ(reader.manifest().stats.surfel_count, surfels.size()) << name;
    const PageSetInspection r = inspect_page_set(reader);  // verifies every page
    EXPECT_TRUE(r.consistent) << name;
    EXPECT_EQ(test::walk_digest(reader), kDigest) << name;
    // This build's tree of the same surfels (V8: rounded frames and bounds)
    // differs, in values only: the same nodes and leaves.
    EXPECT_NE(test::walk_digest(today), kDigest);
    EXPECT_EQ(r.nodes, today.page(0)->nodes.size()) << name;
  }
}

}  // namespace
}  // namespace pbgi::storage
