// A TreeSource over a tree held in memory, as one page (id 0). For tests and
// tools that want to gather without writing a page set.
// Thread-safety: immutable after construction.
#pragma once

#include "storage/tree/node.h"
#include "storage/tree/tree_builder.h"

namespace pbgi::tree {

class MemoryTree final : public TreeSource {
 public:
  explicit MemoryTree(BuiltTree tree);

  NodeRef root() const override { return {0, 0}; }
  // Throws InvalidArgument for any id but 0.
  PagePtr page(uint32_t id) const override;

 private:
  PagePtr page_;
};

}  // namespace pbgi::tree
