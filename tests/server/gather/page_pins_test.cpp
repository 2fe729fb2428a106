// PagePins (server/gather/page_pins.h): what a batch keeps pinned between
// its runs of receivers, within a bound in bytes.
#include "server/gather/page_pins.h"
#include "server/gather/page_views.h"
#include "surfel_shapes.h"
#include "surfel_tree.h"

#include <gtest/gtest.h>

#include <vector>

namespace pbgi {
namespace {

test::SurfelTree four_page_tree() {
  std::vector<Surfel> s;
  test::add_disk(s, {0, 0, 0}, {0, 0, 1}, 1.f, 200, Imath::C3f(0.5f));
  test::SurfelTreeOptions o;
  o.nodes_per_page = 16;
  return test::SurfelTree(std::move(s), o);
}

// Acquires page `id` and drops the reference again (the page stays pinned
// only while the pins hold).
void touch(gather::PagePins& pins, uint32_t id) {
  const tree::Page* page = nullptr;
  const gather::PageView* view = nullptr;
  pins.release(pins.acquire(id, page, view));
}

// trim keeps pinned the pages the most recent runs used, within a bound
// in bytes: one the next run acquires again is not fetched again; the
// least recently used are unpinned first. (Before, a batch kept only the
// last run's pages, counted in pages: a quarter more fetches on the 2M
// city, factorized_gather.cpp.)
TEST(PagePins, TrimKeepsTheMostRecentlyUsedPagesWithinItsBytes) {
  const test::SurfelTree tree = four_page_tree();
  ASSERT_GE(tree.page_count(), 4u);
  gather::PageViews views;
  gather::PagePins pins(tree, views);
  pins.set_hold(true);

  std::vector<uint64_t> bytes;
  for (uint32_t id = 0; id < 3; ++id) {
    const uint64_t before = pins.pinned_bytes();
    touch(pins, id);
    bytes.push_back(pins.pinned_bytes() - before);
    ASSERT_GT(bytes.back(), 0u);
  }
  pins.next_run();
  touch(pins, 1);
  const uint64_t before = pins.pinned_bytes();
  touch(pins, 3);
  bytes.push_back(pins.pinned_bytes() - before);
  EXPECT_EQ(tree.fetches(), 4u);  // page 1 was still pinned
  pins.next_run();
  pins.trim(pins.pinned_bytes());  // within the bound: nothing unpinned
  EXPECT_EQ(pins.pinned(), 4u);

  pins.trim(bytes[1] + bytes[3]);  // run 2 used 1 and 3: 0 and 2 unpinned
  EXPECT_EQ(pins.pinned(), 2u);
  EXPECT_EQ(pins.pinned_bytes(), bytes[1] + bytes[3]);
  EXPECT_EQ(tree.pages_in_use(), 2u);
  touch(pins, 3);
  touch(pins, 0);
  EXPECT_EQ(tree.fetches(), 5u);  // 3 kept, 0 fetched again

  pins.next_run();
  pins.trim(bytes[0] + bytes[3]);  // run 3 used 3 and 0: 1 unpinned
  EXPECT_EQ(pins.pinned(), 2u);
  touch(pins, 0);
  touch(pins, 3);
  EXPECT_EQ(tree.fetches(), 5u);
  pins.trim(0);
  EXPECT_EQ(pins.pinned(), 0u);
  EXPECT_EQ(pins.pinned_bytes(), 0u);
  EXPECT_EQ(tree.pages_in_use(), 0u);

  touch(pins, 3);
  EXPECT_EQ(tree.fetches(), 6u);
  pins.set_hold(false);
  pins.clear();
  EXPECT_EQ(tree.pages_in_use(), 0u);
}

// A page a pending entry refers to stays pinned whatever the bound: trim
// runs between a cluster's receivers while its near entries hold pages.
TEST(PagePins, TrimKeepsReferencedPages) {
  const test::SurfelTree tree = four_page_tree();
  gather::PageViews views;
  gather::PagePins pins(tree, views);
  pins.set_hold(true);
  const tree::Page* page = nullptr;
  const gather::PageView* view = nullptr;
  const uint32_t held = pins.acquire(0, page, view);  // referenced
  touch(pins, 1);
  touch(pins, 2);
  pins.next_run();
  pins.trim(0);
  EXPECT_EQ(pins.pinned(), 1u);
  EXPECT_EQ(tree.pages_in_use(), 1u);
  EXPECT_EQ(&pins.view(held), view) << "the referenced slot is where it was";
  pins.release(held);
  pins.trim(0);
  EXPECT_EQ(pins.pinned(), 0u);
  pins.set_hold(false);
  pins.clear();
}

// compact forgets the slots of unpinned pages between runs; the pinned
// ones stay pinned and are not fetched again.
TEST(PagePins, CompactKeepsThePinnedPages) {
  std::vector<Surfel> s;
  test::add_disk(s, {0, 0, 0}, {0, 0, 1}, 1.f, 12000, Imath::C3f(0.5f));
  test::SurfelTreeOptions o;
  o.nodes_per_page = 4;
  const test::SurfelTree tree(std::move(s), o);
  ASSERT_GT(tree.page_count(), 1100u) << "more slots than compact() leaves alone";
  gather::PageViews views;
  gather::PagePins pins(tree, views);
  pins.set_hold(true);
  const auto n = uint32_t(tree.page_count());
  for (uint32_t id = 0; id < n; ++id) touch(pins, id);
  pins.next_run();
  pins.trim(0);  // every slot stays, none pinned
  EXPECT_EQ(pins.pinned(), 0u);
  touch(pins, 0);
  touch(pins, 1);
  const uint64_t keep = pins.pinned_bytes();
  pins.compact();
  EXPECT_EQ(pins.pinned(), 2u);
  EXPECT_EQ(pins.pinned_bytes(), keep);
  const uint64_t fetched = tree.fetches();
  touch(pins, 0);
  touch(pins, 1);
  EXPECT_EQ(tree.fetches(), fetched) << "still pinned after compact()";
  touch(pins, 2);
  EXPECT_EQ(tree.fetches(), fetched + 1);
  EXPECT_EQ(tree.pages_in_use(), 3u);
  pins.set_hold(false);
  pins.clear();
  EXPECT_EQ(tree.pages_in_use(), 0u);
}

}  // namespace
}  // namespace pbgi
