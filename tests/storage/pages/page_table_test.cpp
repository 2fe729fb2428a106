// The page table: the extents it is given, back, in ~2.25 bytes a page
// when pages lie back to back.
#include "storage/pages/page_table.h"

#include <gtest/gtest.h>

#include <random>
#include <stdexcept>

namespace pbgi::storage {
namespace {

std::vector<PageExtent> back_to_back(size_t n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::vector<PageExtent> out;
  uint64_t at = 0;
  for (size_t i = 0; i < n; ++i) {
    // Mostly small pages, with the 16-bit edge and larger ones among them.
    const uint32_t r = rng() % 100;
    const uint32_t bytes = r == 0 ? 65535u : r == 1 ? 65536u : r == 2 ? (1u << 30) + rng() % 1000 : 20 + rng() % 600;
    out.push_back({at, bytes});
    at += bytes;
  }
  return out;
}

TEST(PageTable, ReturnsTheExtentsOfPagesBackToBackInLittleMemory) {
  const std::vector<PageExtent> want = back_to_back(100000, 1);
  PageTable t;
  for (const PageExtent& e : want) t.push_back(e);
  ASSERT_EQ(t.size(), want.size());
  EXPECT_TRUE(t.back_to_back());
  for (uint32_t id = 0; id < want.size(); ++id) ASSERT_EQ(t[id], want[id]) << id;
  uint32_t id = 0;
  for (const PageExtent e : t) EXPECT_EQ(e, want[id++]);
  EXPECT_EQ(id, want.size());
  t.shrink_to_fit();
  // 2.25 bytes a page and 8 for each of the 3% large ones; 16 as a vector
  // of extents.
  EXPECT_LT(double(t.memory_bytes()) / double(want.size()), 2.6);
  EXPECT_THROW(t.at(uint32_t(want.size())), std::out_of_range);
}

TEST(PageTable, PagesNotBackToBackKeepTheirOffsets) {
  // Older manifests store offsets; a gap (or a page out of order) keeps
  // every extent as given, before and after it.
  std::vector<PageExtent> want = back_to_back(100, 2);
  want[70].offset += 8;
  want[71].offset = 0;
  PageTable t;
  for (const PageExtent& e : want) t.push_back(e);
  EXPECT_FALSE(t.back_to_back());
  for (uint32_t id = 0; id < want.size(); ++id) ASSERT_EQ(t[id], want[id]) << id;

  PageTable same;
  for (const PageExtent& e : want) same.push_back(e);
  EXPECT_EQ(t, same);
  PageTable other = {{0, 10}, {10, 20}};
  EXPECT_FALSE(t == other);
  EXPECT_EQ(other[1], (PageExtent{10, 20}));
}

}  // namespace
}  // namespace pbgi::storage
