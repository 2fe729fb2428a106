// Options of the tree build and page layout (documented defaults).
#pragma once

#include <cstdint>

namespace pbgi::tree {

struct BuildOptions {
  uint32_t leaf_size = 4;        // max surfels per leaf node
  uint32_t page_size = 65536;    // target bytes per page on disk

  void validate() const;  // throws pbgi::InvalidArgument
};

}  // namespace pbgi::tree
