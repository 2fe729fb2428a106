// Options of the tree build and page layout (documented defaults).
#pragma once

#include <cstdint>

namespace pbgi::tree {

struct BuildOptions {
  uint32_t leaf_size = 4;        // max surfels per leaf node (1..4096)
  uint32_t page_size = 65536;    // max bytes per page on disk
  // Memory for sorting surfels by Morton code: the run buffer while surfels
  // arrive, then all merge buffers together. Runs beyond it go to disk.
  // Changes only speed and memory, never the page set (so it is neither
  // stored in the manifest nor part of build keys).
  uint64_t sort_memory_bytes = uint64_t(256) << 20;

  void validate() const;  // throws pbgi::InvalidArgument
};

}  // namespace pbgi::tree
