// Test helper: a TreeSource built in memory from a vector of surfels, laid
// out over several pages so that traversals cross page links. Independent
// of storage/tree's builder on purpose: the gather tests check the gather
// against the node contract of storage/tree/node.h, not against one builder.
//
// Tree: binary, median split along the largest axis of the surfel centers,
// leaves of at most leaf_size surfels. Nodes in depth-first pre-order;
// page p holds nodes [p * nodes_per_page, (p + 1) * nodes_per_page) and the
// surfels of its leaves. An empty surfel list gives a single empty leaf.
#pragma once

#include "storage/tree/node.h"
#include "storage/tree/surfel.h"

#include <atomic>
#include <cstdint>
#include <memory>
#include <vector>

namespace pbgi::test {

struct SurfelTreeOptions {
  uint32_t leaf_size = 4;
  uint32_t nodes_per_page = 64;
};

class SurfelTree final : public tree::TreeSource {
 public:
  explicit SurfelTree(std::vector<Surfel> surfels, SurfelTreeOptions options = {});

  tree::NodeRef root() const override { return {0, 0}; }
  tree::PagePtr page(uint32_t id) const override;

  size_t page_count() const { return pages_.size(); }
  size_t node_count() const { return node_count_; }
  // page() calls so far.
  uint64_t fetches() const { return fetches_.load(); }
  // Pages currently referenced by someone besides this source.
  size_t pages_in_use() const;
  // The most pages referenced outside this source at any page() call.
  size_t max_pages_in_use() const { return max_in_use_.load(); }

 private:
  std::vector<std::shared_ptr<tree::Page>> pages_;
  // Outstanding references handed out per page, and pages with any: each
  // page() returns a handle whose deleter counts down (cheap enough to keep
  // out of the way of benchmarks, unlike scanning every page).
  std::unique_ptr<std::atomic<uint32_t>[]> refs_;
  mutable std::atomic<size_t> in_use_{0};
  size_t node_count_ = 0;
  mutable std::atomic<uint64_t> fetches_{0};
  mutable std::atomic<size_t> max_in_use_{0};
};

}  // namespace pbgi::test
