// The packing of a tree into treelet pages.
#include "storage/format/errors.h"
#include "storage/pages/page_layout.h"
#include "tests/storage/tree/random_surfels.h"

#include <gtest/gtest.h>

namespace pbgi::storage {
namespace {

TEST(PageLayout, PagesAreConnectedSubtreesWithinBudget) {
  tree::BuildOptions opt;
  opt.leaf_size = 5;
  const tree::BuiltTree t = tree::build_tree(test::random_surfels(5000, 9), opt);
  for (uint64_t budget : {1000u, 4000u, 30000u, 10000000u}) {
    const uint64_t node_bytes = 208, surfel_bytes = 64;
    const PagePlan plan = plan_pages(t, budget, node_bytes, surfel_bytes);
    const size_t n = t.nodes.size();
    ASSERT_EQ(plan.page_of.size(), n);

    std::vector<uint32_t> parent(n, UINT32_MAX);
    for (uint32_t i = 0; i < n; ++i)
      for (uint32_t c = 0; c < t.nodes[i].child_count; ++c) parent[t.nodes[i].children[c].index] = i;

    std::vector<uint64_t> bytes(plan.page_count(), 0);
    std::vector<uint32_t> size(plan.page_count(), 0);
    for (uint32_t i = 0; i < n; ++i) {
      const uint32_t p = plan.page_of[i];
      ASSERT_LT(p, plan.page_count());
      bytes[p] += node_bytes + t.nodes[i].surfel_count * surfel_bytes;
      size[p]++;
      // Connected: every node but a page root has its parent in its page.
      if (plan.page_root[p] == i) {
        ASSERT_EQ(plan.index_in_page[i], 0u);
      } else {
        ASSERT_NE(parent[i], UINT32_MAX);
        ASSERT_EQ(plan.page_of[parent[i]], p) << "node " << i;
        ASSERT_GT(plan.index_in_page[i], plan.index_in_page[parent[i]]);
      }
    }
    uint64_t total = 0;
    for (uint32_t p = 0; p < plan.page_count(); ++p) {
      ASSERT_LE(bytes[p], budget) << "page " << p;
      total += bytes[p];
      std::vector<uint32_t> nodes;
      page_nodes(t, plan, p, nodes);
      ASSERT_EQ(nodes.size(), size[p]);
      for (uint32_t k = 0; k < nodes.size(); ++k) {
        ASSERT_EQ(plan.index_in_page[nodes[k]], k);
      }
    }
    // Depth-first page order: page roots in tree pre-order.
    for (uint32_t p = 1; p < plan.page_count(); ++p) {
      ASSERT_GT(plan.page_root[p], plan.page_root[p - 1]);
    }
    if (budget >= total) {
      EXPECT_EQ(plan.page_count(), 1u);
    }
    // At most one page per ~half budget (plus the root page).
    EXPECT_LE(plan.page_count(), 2 * total / budget + 2) << "budget " << budget;
  }
}

TEST(PageLayout, LeafLargerThanAPageIsRefused) {
  tree::BuildOptions opt;
  opt.leaf_size = 16;
  const tree::BuiltTree t = tree::build_tree(test::random_surfels(100), opt);
  EXPECT_THROW(plan_pages(t, 500, 208, 64), InvalidArgument);
}

}  // namespace
}  // namespace pbgi::storage
