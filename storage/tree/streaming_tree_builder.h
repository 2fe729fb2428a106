// Bottom-up build of the tree from a stream of surfels sorted by Morton
// code, with memory bounded by the page size, not by the surfel count.
//
// Tree. The binary radix tree of the sorted keys (Karras 2012): a node
// splits where its keys first differ, i.e. along the highest Morton bit
// that varies below it, so every node covers a cell of an octree-like
// subdivision of space and far-apart surfels never share a small node.
// Equal codes are told apart by the surfel's position in the stream, which
// splits a run of equal codes into a balanced subtree. A subtree of at most
// leaf_size surfels becomes one leaf.
//
// Streaming. Between consecutive keys lies a separator whose level is the
// highest differing bit; the tree is the Cartesian tree of the separators,
// built left to right with a stack of open subtrees (levels strictly
// decrease up the stack, so it never holds more than 128 entries). A node
// is created once both its children are complete: nodes complete in
// post-order.
//
// Pages. Each open subtree carries the nodes not yet written (its pending
// treelet) and their size on disk. When joining two children would exceed
// a page, the larger pending child is written as a page of its own and the
// parent keeps a link to it; so every page is a connected treelet holding
// whole bottom parts of the tree, pages are written as soon as they are
// full, and a top-down walk crosses few pages. A page links only to pages
// written before it; the root's page is the last.
//
// Air regions (region_grid.h). The stream is sorted by region first; the
// separator between two regions lies above every Morton level, so each
// region's surfels form one subtree, which is written as a page of its own
// (its root is that page's node 0) and listed in the stats' region_roots.
// A stream of one region builds the same tree as before regions existed.
//
// Leaves are quantized when they are closed (leaf_quantizer.h) and every
// summary is computed from the decoded surfels, as a reader will.
//
// Stored node payloads. Given a NodePayloadSizer, every node's stored size
// is taken as it completes (node_payload_sizer.h) and counts towards its
// page's size, and each treelet carries its nodes' exact summaries for the
// page writer's codec; links then carry no payload (the linked child's
// payload is in its own page).
//
// Thread-safety: one builder per thread; not copyable.
#pragma once

#include "storage/tree/build_options.h"
#include "storage/tree/node.h"
#include "storage/tree/node_payload_sizer.h"
#include "storage/tree/region_grid.h"
#include "storage/tree/surfel.h"
#include "storage/tree/treelet.h"

#include <cstdint>
#include <memory>
#include <vector>

namespace pbgi::tree {

// Receives the treelets as they are completed.
class TreeletSink {
 public:
  virtual ~TreeletSink() = default;
  // Stores `t` as the next page and returns its id (0, 1, 2, ...).
  virtual uint32_t write(const Treelet& t) = 0;
};

struct StreamingTreeStats {
  uint64_t surfel_count = 0;
  uint64_t node_count = 0;
  uint64_t leaf_count = 0;
  uint32_t max_depth = 0;         // of the deepest leaf; the root has depth 0
  uint32_t page_count = 0;
  NodeRef root;                   // {last page, 0}
  uint64_t peak_pending_bytes = 0;  // most memory held by nodes not yet written
  // Each region's subtree, by increasing region, when the stream held more
  // than one region (empty otherwise).
  std::vector<RegionRoot> region_roots;
};

class StreamingTreeBuilder {
 public:
  // `page_bytes`: the most bytes a page may take on disk (options.page_size),
  // or 0 for a single unbounded page (in-memory trees). `link_payload_bytes`:
  // what a page stores per link besides the link record (the codec's
  // payload; 0 with a sizer). `sizer`: every node's payload is stored, of
  // the size it says (null: payloads derived at load, V2 pages); must
  // outlive the builder.
  // Throws InvalidArgument for invalid options.
  StreamingTreeBuilder(const BuildOptions& options, uint64_t page_bytes, uint64_t link_payload_bytes,
                       TreeletSink& sink, const NodePayloadSizer* sizer = nullptr);
  ~StreamingTreeBuilder();
  StreamingTreeBuilder(const StreamingTreeBuilder&) = delete;
  StreamingTreeBuilder& operator=(const StreamingTreeBuilder&) = delete;

  // Appends the next surfel of the stream (valid: finite, unit normal,
  // radius >= 0, colours >= 0) with its Morton code. (region, code) must
  // not decrease: InvalidArgument otherwise; several regions need pages
  // (page_bytes > 0).
  void add(const Surfel& s, uint64_t code);

  // Closes the tree and writes the remaining pages. InvalidArgument if no
  // surfel was added. The builder is spent afterwards.
  StreamingTreeStats finish();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace pbgi::tree
