// The decoded form of tree nodes and pages, as the gather sees them.
// Whatever codec a page set uses on disk, a page is decoded into this form
// when it enters the cache, so the gather has one fast path.
//
// A node's payload describes the outgoing radiance of all surfels below it
// as area-averaged spherical functions:
//   radiance_sh(w)  ~ (1/A) sum_i A_i L_i max(0, n_i.w)   (RGB, 27 floats)
//   coverage_sh(w)  ~ (1/A) sum_i A_i     max(0, n_i.w)   (9 floats)
// Seen from direction w the node covers a projected area A*coverage(w) and
// shows radiance radiance(w)/coverage(w).
#pragma once

#include "storage/sh/sh.h"
#include "storage/tree/surfel.h"

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

namespace pbgi::storage {
class GlossyNodes;  // storage/codecs/glossy_pages.h
}

namespace pbgi::tree {

// A link to a node: the page that holds it and its index in that page.
struct NodeRef {
  uint32_t page = 0;
  uint32_t index = 0;
  bool operator==(const NodeRef&) const = default;
};

struct Node {
  Imath::V3f center;        // bounding sphere of all surfel disks below
  float radius = 0.f;
  Imath::V3f cone_axis;     // normal cone: all normals within acos(cone_cos)
  float cone_cos = -1.f;    // -1 = normals in every direction
  float area = 0.f;         // sum of surfel areas below
  uint32_t child_count = 0; // internal: number of children (1..kMaxChildren); leaf: 0
  uint32_t first_surfel = 0;  // leaf: index into the page's surfel array
  uint32_t surfel_count = 0;  // leaf: number of surfels
  static constexpr int kMaxChildren = 2;
  NodeRef children[kMaxChildren];
  sh::ShRgb radiance_sh;
  sh::Sh9 coverage_sh{};

  bool is_leaf() const { return child_count == 0; }
};

// What a heap block of `n` requested bytes occupies (glibc's malloc: an
// 8-byte size header, 16-byte granularity, 32 bytes at least): memory
// charges count blocks, not the bytes asked for. For the small blocks of
// a cut-shaped page (~10 nodes) the difference is a tenth of its charge.
constexpr size_t heap_block_bytes(size_t n) {
  const size_t block = (n + 8 + 15) / 16 * 16;
  return block < 32 ? 32 : block;
}

// What a reader of pages derives from one page once and keeps with it (the
// gather's compact node views). It lives and dies with its page, so the
// page cache charges its bytes together with the page's and one budget
// bounds all the memory pages cost; nothing derived outlives an eviction.
struct PageAttachment {
  virtual ~PageAttachment() = default;
  virtual size_t memory_bytes() const = 0;
};

// A child that lives in another page, as the parent's page describes it:
// which node's which child slot it is and its exact summary (bounds, cone,
// area and payload: what the child's own page derives for its root). A
// reader can decide on such a child (cull it, splat it) without loading its
// page; it needs the page only to open the child.
struct PageLink {
  uint32_t parent = 0;  // index of the parent node in this page
  uint32_t slot = 0;    // which child of the parent
  Node summary;         // children[0] = {the child's page, 0}
};

// One decoded page: a subtree (treelet) of nodes and the surfels of its leaves.
struct Page {
  uint32_t id = 0;
  std::vector<Node> nodes;
  std::vector<Surfel> surfels;
  // The children in other pages with summaries equal to their pages'
  // roots, when the page stores them exactly (derived-payload pages without
  // glossy radiance: storage/pages/page_encoding.h); empty otherwise, and
  // then a reader must load a linked child's page to see it.
  std::vector<PageLink> links;
  // Set by the page's loader before the page is shared (PageDecorator in
  // storage/pages/page_set.h), never after: readers need no lock.
  std::shared_ptr<const PageAttachment> attachment;
  // Glossy senders' outgoing radiance (wavelet cube maps) of the page's
  // nodes, or null when the page shows none; glossy_bytes is its memory.
  std::shared_ptr<const storage::GlossyNodes> glossy;
  size_t glossy_bytes = 0;

  // Heap blocks included: the page's own (with the control block of the
  // std::make_shared that every loader uses), its arrays' and its
  // attachment's.
  size_t memory_bytes() const {
    auto array = [](size_t bytes) { return bytes ? heap_block_bytes(bytes) : 0; };
    return heap_block_bytes(kSharedControlBytes + sizeof(Page)) + array(nodes.capacity() * sizeof(Node)) +
           array(surfels.capacity() * sizeof(Surfel)) + array(links.capacity() * sizeof(PageLink)) +
           (attachment ? attachment->memory_bytes() : 0) + glossy_bytes;
  }
  // std::make_shared's control block (use and weak counts, vtable).
  static constexpr size_t kSharedControlBytes = 16;
};

using PagePtr = std::shared_ptr<const Page>;

class RegionGrid;  // storage/tree/region_grid.h

// The subtree of one air region's surfels (region_grid.h): a page's root
// (streaming_tree_builder.h).
struct RegionRoot {
  uint32_t region = 0;
  NodeRef root;
  bool operator==(const RegionRoot&) const = default;
};

// Read access to a tree whose pages may live on disk. Implementations are
// thread-safe: many gathers traverse one tree concurrently.
class TreeSource {
 public:
  virtual ~TreeSource() = default;
  virtual NodeRef root() const = 0;
  // Returns the page, loading and decoding it if needed. Throws
  // pbgi::CorruptionError, VersionError or IoError (common/errors.h)
  // naming the page on failure.
  virtual PagePtr page(uint32_t id) const = 0;
  // Page `id`'s attachment (PageAttachment), from a source that keeps only
  // the attachments its page decorator derives (a PageSetReader with a
  // decorator, storage/pages/page_set.h): pinning it costs what the
  // attachment costs, no Page. Null from a source that keeps whole pages:
  // then call page(). Throws as page().
  virtual std::shared_ptr<const PageAttachment> attachment(uint32_t /*id*/) const { return nullptr; }
  // Air regions (region_grid.h): the grid receivers are looked up in and
  // each region's subtree, by increasing region; null and empty when the
  // tree does not keep regions apart (a receiver then walks root()).
  virtual const RegionGrid* regions() const { return nullptr; }
  virtual std::span<const RegionRoot> region_roots() const { return {}; }
};

}  // namespace pbgi::tree
