// PagePins (server/gather/page_pins.h): what a batch keeps pinned between
// its runs of receivers.
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

// keep_recent keeps pinned the pages of the last run only: one the next
// run acquires again is not fetched again; one the last run did not use is
// unpinned. Before keep_recent a batch could only clear: every page of the
// next run was fetched again.
TEST(PagePins, KeepRecentKeepsOnlyTheLastRunsPages) {
  const test::SurfelTree tree = four_page_tree();
  ASSERT_GE(tree.page_count(), 4u);
  gather::PageViews views;
  gather::PagePins pins(tree, views);
  pins.set_hold(true);

  touch(pins, 0);
  touch(pins, 1);
  touch(pins, 2);
  pins.keep_recent(100);  // run 1 used 0, 1, 2: all kept
  EXPECT_EQ(pins.pinned(), 3u);
  EXPECT_EQ(tree.pages_in_use(), 3u);

  touch(pins, 1);
  touch(pins, 3);
  EXPECT_EQ(tree.fetches(), 4u);  // page 1 was still pinned
  pins.keep_recent(100);          // run 2 used 1 and 3: 0 and 2 unpinned
  EXPECT_EQ(pins.pinned(), 2u);
  EXPECT_EQ(tree.pages_in_use(), 2u);

  touch(pins, 3);
  touch(pins, 0);
  EXPECT_EQ(tree.fetches(), 5u);  // 3 kept, 0 fetched again
  pins.keep_recent(1);            // more than one page used: everything unpinned
  EXPECT_EQ(pins.pinned(), 0u);
  EXPECT_EQ(tree.pages_in_use(), 0u);

  touch(pins, 3);
  EXPECT_EQ(tree.fetches(), 6u);
  pins.set_hold(false);
  pins.clear();
  EXPECT_EQ(tree.pages_in_use(), 0u);
}

}  // namespace
}  // namespace pbgi
