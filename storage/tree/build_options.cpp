#include "storage/tree/build_options.h"

#include "storage/format/errors.h"
#include "storage/format/page_records.h"

#include <string>

namespace pbgi::tree {

void BuildOptions::validate() const {
  constexpr uint32_t kMaxLeafSize = 4096;
  constexpr uint32_t kMaxPageSize = 1u << 30;
  if (leaf_size < 1 || leaf_size > kMaxLeafSize) {
    throw InvalidArgument("tree.leaf_size = " + std::to_string(leaf_size) +
                          ": must be in [1, " + std::to_string(kMaxLeafSize) + "]");
  }
  // Every page must be able to hold one full leaf (a leaf is never split
  // across pages) and one node whose two children live in other pages.
  const size_t min_page = storage::min_page_bytes(leaf_size);
  if (page_size < min_page || page_size > kMaxPageSize) {
    throw InvalidArgument("tree.page_size = " + std::to_string(page_size) + ": must be in [" +
                          std::to_string(min_page) + ", " + std::to_string(kMaxPageSize) +
                          "] for tree.leaf_size = " + std::to_string(leaf_size) +
                          " (a page holds at least one full leaf)");
  }
  constexpr uint64_t kMinSortMemory = 64 * 1024;
  if (sort_memory_bytes < kMinSortMemory) {
    throw InvalidArgument("tree.sort_memory_bytes = " + std::to_string(sort_memory_bytes) +
                          ": must be at least " + std::to_string(kMinSortMemory));
  }
}

}  // namespace pbgi::tree
