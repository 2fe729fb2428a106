// In-memory build of the binary bounding-sphere hierarchy over surfels.
//
// Split rule: at each node, the surfels are split at the median (by count)
// along the largest axis of their centroid bounds; a range of at most
// options.leaf_size surfels becomes a leaf. Because the split is by count,
// the shape of the tree depends only on the surfel count, which lets the
// builder lay nodes out in depth-first pre-order and build subtrees in
// parallel with no allocation or merging.
//
// The result is deterministic: same surfels and options, same bytes.
#pragma once

#include "storage/tree/build_options.h"
#include "storage/tree/node.h"
#include "storage/tree/surfel.h"

#include <cstdint>
#include <vector>

namespace pbgi::tree {

struct BuiltTree {
  // Depth-first pre-order: the root is nodes[0], an internal node's first
  // child follows it directly. Child links are NodeRef{0, index into nodes}.
  std::vector<Node> nodes;
  // The input surfels, reordered so each leaf's surfels are contiguous:
  // a leaf holds surfels[first_surfel, first_surfel + surfel_count).
  std::vector<Surfel> surfels;
  uint64_t leaf_count = 0;
  uint32_t max_depth = 0;  // depth of the deepest leaf; the root has depth 0
};

// Number of nodes of the tree over `surfel_count` surfels (0 for none).
uint64_t tree_node_count(uint64_t surfel_count, uint32_t leaf_size);

// Builds the tree over `surfels` (consumed). Normals are renormalized.
// Throws InvalidArgument for invalid options, no surfels, more than 2^31
// surfels, or a surfel with a non-finite field, negative radius or zero
// normal (naming its index). Uses the TBB thread pool.
BuiltTree build_tree(std::vector<Surfel> surfels, const BuildOptions& options);

}  // namespace pbgi::tree
