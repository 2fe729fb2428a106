// Packing of a built tree into pages: each page holds a connected subtree
// (a treelet) of at most `budget` bytes of records; the children of its
// bottom nodes are the roots of other pages.
//
// Packing is bottom-up greedy (post-order): a node's pending size is its own
// records plus the pending subtrees of its children; while that exceeds the
// budget, the child with the largest pending subtree is cut off and becomes
// the root of its own page. Cut subtrees are as large as possible, so pages
// are at least about half full, and a root-to-leaf path crosses few pages.
// Pages are numbered depth-first from the root's page (id 0), so pages close
// in the tree are close in the file.
#pragma once

#include "storage/tree/tree_builder.h"

#include <cstdint>
#include <vector>

namespace pbgi::storage {

struct PagePlan {
  std::vector<uint32_t> page_of;        // per built node: its page id
  std::vector<uint32_t> index_in_page;  // per built node: its index in the page
  std::vector<uint32_t> page_root;      // per page: the built node at its root
  uint32_t page_count() const { return static_cast<uint32_t>(page_root.size()); }
};

// `budget`: bytes of records a page may hold; `node_bytes` and
// `surfel_bytes`: on-disk bytes per node and per surfel.
// Precondition (checked, InvalidArgument): a leaf of the tree fits the budget.
PagePlan plan_pages(const tree::BuiltTree& tree, uint64_t budget, uint64_t node_bytes,
                    uint64_t surfel_bytes);

// Collects the nodes of page `page` in the order of their index in the page
// (depth-first pre-order from the page's root); `out` is cleared first.
void page_nodes(const tree::BuiltTree& tree, const PagePlan& plan, uint32_t page,
                std::vector<uint32_t>& out);

}  // namespace pbgi::storage
