// In-memory build of the tree over surfels: the same tree, bit for bit, as
// the streaming build of storage/pages writes to disk
// (streaming_tree_builder.h describes it), held as one unbounded page. For
// tests, tools and small trees; page sets go through build_page_set().
//
// The result is deterministic: same surfels and options, same tree.
#pragma once

#include "storage/tree/build_options.h"
#include "storage/tree/node.h"
#include "storage/tree/surfel.h"

#include <Imath/ImathBox.h>

#include <cstdint>
#include <vector>

namespace pbgi::tree {

struct BuiltTree {
  // Depth-first pre-order: the root is nodes[0], an internal node's first
  // child follows it directly. Child links are NodeRef{0, index into nodes}.
  std::vector<Node> nodes;
  // The input surfels as stored (quantized relative to their leaf, see
  // storage/tree/page_records.h), in leaf order: a leaf holds
  // surfels[first_surfel, first_surfel + surfel_count).
  std::vector<Surfel> surfels;
  uint64_t leaf_count = 0;
  uint32_t max_depth = 0;  // depth of the deepest leaf; the root has depth 0
};

// The box the Morton order is taken over: the bounds of the positions.
Imath::Box3f surfel_bounds(const std::vector<Surfel>& surfels);

// Builds the tree over `surfels` (consumed) in the Morton order of
// `surfel_bounds(surfels)`, ties in input order, as build_page_set() does.
// Throws InvalidArgument for invalid options, no surfels, more than 2^31
// surfels, or an invalid surfel (surfel_checks.h, naming its index).
BuiltTree build_tree(std::vector<Surfel> surfels, const BuildOptions& options);

}  // namespace pbgi::tree
