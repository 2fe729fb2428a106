// Packing of a built tree into pages: each page holds a connected subtree
// (a treelet) of at most `budget` bytes of records; the children of its
// bottom nodes are the roots of other pages.
//
// Packing is top-down and size-aware: a page grows breadth-first from its
// root; a child subtree that fits the space left joins whole, one that fits
// a page of its own becomes its own page (never split into fragments), and
// a larger one contributes its top node and is expanded further. On the
// balanced trees of the builder this gives few pages per root-to-leaf path
// (the out-of-core traversal cost): the upper tree in wide treelets of
// internal nodes, the lower tree in whole subtrees with their surfels.
// Pages are numbered depth-first from the root's page (id 0), so pages
// close in the tree are close in the file; nodes within a page are in
// depth-first pre-order from the page's root (index 0).
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
