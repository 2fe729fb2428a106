#include "storage/pages/page_layout.h"

#include "storage/format/errors.h"

#include <algorithm>
#include <deque>
#include <functional>
#include <limits>
#include <string>

namespace pbgi::storage {

namespace {
constexpr uint32_t kUnassigned = std::numeric_limits<uint32_t>::max();
}

PagePlan plan_pages(const tree::BuiltTree& t, uint64_t budget, uint64_t node_bytes,
                    uint64_t surfel_bytes) {
  const size_t n = t.nodes.size();
  PagePlan plan;
  if (n == 0) return plan;
  auto own = [&](uint32_t i) { return node_bytes + uint64_t(t.nodes[i].surfel_count) * surfel_bytes; };

  // 1. Bytes of every subtree. In pre-order children come after their
  //    parent, so a reverse sweep is a post-order.
  std::vector<uint64_t> subtree(n);
  for (size_t i = n; i-- > 0;) {
    const tree::Node& node = t.nodes[i];
    uint64_t total = own(static_cast<uint32_t>(i));
    if (total > budget) {
      throw InvalidArgument("node " + std::to_string(i) + " needs " + std::to_string(total) +
                            " bytes, more than a page holds (" + std::to_string(budget) +
                            "); raise tree.page_size or lower tree.leaf_size");
    }
    for (uint32_t c = 0; c < node.child_count; ++c) total += subtree[node.children[c].index];
    subtree[i] = total;
  }

  // 2. Top-down: grow each page breadth-first from its root. A subtree that
  //    fits the space left joins whole; one that fits a page of its own is
  //    never split (that would leave fragments); a larger one contributes
  //    its top node and is expanded further. What does not fit starts a
  //    page of its own.
  plan.page_of.assign(n, kUnassigned);
  plan.index_in_page.assign(n, kUnassigned);
  std::vector<uint32_t> roots{0}, new_roots, stack;
  std::deque<uint32_t> frontier;
  auto add_subtree = [&](uint32_t x, uint32_t page) {
    stack.assign(1, x);
    while (!stack.empty()) {
      const uint32_t y = stack.back();
      stack.pop_back();
      plan.page_of[y] = page;
      const tree::Node& node = t.nodes[y];
      for (uint32_t c = 0; c < node.child_count; ++c) stack.push_back(node.children[c].index);
    }
  };
  while (!roots.empty()) {
    const uint32_t root = roots.back();
    roots.pop_back();
    const uint32_t page = static_cast<uint32_t>(plan.page_root.size());
    plan.page_root.push_back(root);
    uint64_t used = 0;
    new_roots.clear();
    frontier.assign(1, root);
    while (!frontier.empty()) {
      const uint32_t x = frontier.front();
      frontier.pop_front();
      if (subtree[x] <= budget - used) {
        add_subtree(x, page);
        used += subtree[x];
      } else if (x != root && (subtree[x] <= budget || own(x) > budget - used)) {
        new_roots.push_back(x);
      } else {
        plan.page_of[x] = page;
        used += own(x);
        const tree::Node& node = t.nodes[x];
        for (uint32_t c = 0; c < node.child_count; ++c) frontier.push_back(node.children[c].index);
      }
    }
    // Built nodes are numbered in pre-order: pushing the new roots in
    // descending order makes the leftmost one the next page, so pages are
    // numbered depth-first and neighbours in the tree are near in the file.
    std::sort(new_roots.begin(), new_roots.end(), std::greater<>());
    roots.insert(roots.end(), new_roots.begin(), new_roots.end());
  }
  if (plan.page_root.size() > std::numeric_limits<uint32_t>::max() - 1) {
    throw InvalidArgument("tree needs more than 2^32 pages; raise tree.page_size");
  }

  // 3. Index of each node in its page: depth-first pre-order from the root.
  std::vector<uint32_t> members;
  for (uint32_t page = 0; page < plan.page_count(); ++page) {
    page_nodes(t, plan, page, members);
    for (uint32_t k = 0; k < members.size(); ++k) plan.index_in_page[members[k]] = k;
  }
  return plan;
}

void page_nodes(const tree::BuiltTree& t, const PagePlan& plan, uint32_t page,
                std::vector<uint32_t>& out) {
  out.clear();
  std::vector<uint32_t> stack{plan.page_root[page]};
  while (!stack.empty()) {
    const uint32_t x = stack.back();
    stack.pop_back();
    out.push_back(x);
    const tree::Node& node = t.nodes[x];
    for (uint32_t c = node.child_count; c-- > 0;) {
      const uint32_t ci = node.children[c].index;
      if (plan.page_of[ci] == page) stack.push_back(ci);
    }
  }
}

}  // namespace pbgi::storage
