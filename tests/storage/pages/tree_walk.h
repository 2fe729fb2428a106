// Walks a whole tree through a TreeSource (depth-first, child 0 first), so
// two sources can be compared node by node regardless of how they page.
#pragma once

#include "storage/tree/node.h"

#include <gtest/gtest.h>

#include <functional>
#include <set>
#include <vector>

namespace pbgi::test {

struct Walk {
  std::vector<tree::Node> nodes;     // in visiting order
  std::vector<uint32_t> depth;
  std::vector<Surfel> surfels;       // leaf surfels in visiting order
  std::set<uint32_t> pages;          // pages touched
};

// `after_page` runs after every page() call (e.g. to check cache counters).
inline Walk walk(const tree::TreeSource& src, const std::function<void()>& after_page = {}) {
  Walk w;
  struct Item { tree::NodeRef ref; uint32_t depth; };
  std::vector<Item> stack{{src.root(), 0}};
  while (!stack.empty()) {
    const Item it = stack.back();
    stack.pop_back();
    const tree::PagePtr page = src.page(it.ref.page);
    if (after_page) after_page();
    w.pages.insert(it.ref.page);
    const tree::Node& n = page->nodes.at(it.ref.index);
    w.nodes.push_back(n);
    w.depth.push_back(it.depth);
    if (n.is_leaf()) {
      for (uint32_t k = 0; k < n.surfel_count; ++k) w.surfels.push_back(page->surfels.at(n.first_surfel + k));
    }
    for (uint32_t c = n.child_count; c-- > 0;) stack.push_back({n.children[c], it.depth + 1});
  }
  return w;
}

// Everything but the payload and the links must be equal.
inline void expect_same_geometry(const tree::Node& a, const tree::Node& b, size_t i) {
  ASSERT_EQ(a.center, b.center) << "node " << i;
  ASSERT_EQ(a.radius, b.radius) << "node " << i;
  ASSERT_EQ(a.cone_axis, b.cone_axis) << "node " << i;
  ASSERT_EQ(a.cone_cos, b.cone_cos) << "node " << i;
  ASSERT_EQ(a.area, b.area) << "node " << i;
  ASSERT_EQ(a.child_count, b.child_count) << "node " << i;
  ASSERT_EQ(a.surfel_count, b.surfel_count) << "node " << i;
}

// Everything but the links (which depend on paging) must be equal.
inline void expect_same_content(const tree::Node& a, const tree::Node& b, size_t i) {
  expect_same_geometry(a, b, i);
  if (::testing::Test::HasFatalFailure()) return;
  ASSERT_EQ(a.radiance_sh.r, b.radiance_sh.r) << "node " << i;
  ASSERT_EQ(a.radiance_sh.g, b.radiance_sh.g) << "node " << i;
  ASSERT_EQ(a.radiance_sh.b, b.radiance_sh.b) << "node " << i;
  ASSERT_EQ(a.coverage_sh, b.coverage_sh) << "node " << i;
}

inline void expect_same_walk(const Walk& a, const Walk& b) {
  ASSERT_EQ(a.nodes.size(), b.nodes.size());
  for (size_t i = 0; i < a.nodes.size(); ++i) {
    expect_same_content(a.nodes[i], b.nodes[i], i);
    ASSERT_EQ(a.depth[i], b.depth[i]);
  }
  ASSERT_EQ(a.surfels.size(), b.surfels.size());
  for (size_t i = 0; i < a.surfels.size(); ++i) {
    const Surfel &x = a.surfels[i], &y = b.surfels[i];
    ASSERT_TRUE(x.position == y.position && x.normal == y.normal && x.radius == y.radius &&
                x.albedo == y.albedo && x.emission == y.emission && x.radiance == y.radiance)
        << "surfel " << i;
  }
}

}  // namespace pbgi::test
