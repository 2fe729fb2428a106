#include "storage/tree/memory_tree.h"

#include "common/errors.h"

#include <string>

namespace pbgi::tree {

MemoryTree::MemoryTree(BuiltTree tree) {
  auto p = std::make_shared<Page>();
  p->id = 0;
  p->nodes = std::move(tree.nodes);
  p->surfels = std::move(tree.surfels);
  page_ = std::move(p);
}

PagePtr MemoryTree::page(uint32_t id) const {
  if (id != 0) throw InvalidArgument("in-memory tree has only page 0, asked for page " + std::to_string(id));
  return page_;
}

}  // namespace pbgi::tree
