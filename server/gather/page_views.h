// The gather's own compact view of a tree page: what the traversal's hot
// loop reads per node (bounding sphere, normal cone, precomputed cone
// sine and coplanarity bound, child links) in one 64-byte cache line, and
// in an array of its own what a narrow-cone node shows when it is splatted
// (NodeLook, half a line), apart from the cone and SH payload that only
// wide-cone splats read (WideNode). Building a view costs about one
// pass over the page's nodes; views are cached and reused by every
// receiver, so the cull and cut tests of the ~3500 nodes a receiver visits
// touch one line each and compute no square roots for cones.
//
// The walk is bound by memory latency (perf on bench_gather and pbgi
// bench, docs/gather.md section 12). The child links live in the node's
// own line: in an array of their own, loading them was a cache miss of its
// own (a third of push_children's time). Nodes stay dense, one line each,
// in the depth-first pre-order of the page: a node's first child, popped
// next, is the following line. A node's look is prefetched when the node
// is pushed, so that it is on its way when the node is splatted.
//
// A view is derived from the page's content only. A TreeSource returns the
// same content for a page id for its whole life (pages are immutable), so
// views are keyed by page id and stay valid when the page cache evicts and
// reloads a page; the view never points into the Page. Node and surfel
// links are checked when the view is built (CorruptionError naming the page
// and node).
//
// Thread-safety: none; one per Gatherer.
#pragma once

#include "server/gather/gather.h"
#include "server/gather/node_appearance.h"
#include "storage/codecs/glossy_pages.h"
#include "storage/tree/node.h"

#include <cstdint>
#include <memory>
#include <mutex>
#include <span>
#include <unordered_map>
#include <vector>

namespace pbgi::gather {

// Nodes whose normals all lie within this angle (radians) of the receiver's
// normal are invisible except in the sliver of directions with
// cos(theta) < angle, worth at most angle^2 of the irradiance (4e-4 here).
// Culling them saves refining the receiver's own surface down to leaves.
inline constexpr float kCoplanarAngle = 0.02f;

struct alignas(64) HotNode {
  static constexpr uint32_t kLeaf = 1u << 31;       // in `count`: a leaf
  static constexpr uint32_t kInvisible = 1u << 30;  // in `count`: no area or NaN bounds
  // In `count`: a narrow normal cone (node_appearance.h); its appearance
  // comes from PageView::looks without touching the tree::Node.
  static constexpr uint32_t kNarrow = 1u << 29;
  // In `count`: a wide cone whose normals form two opposite sheets (both
  // faces of a thin wall, node_appearance.h); its appearance comes from
  // PageView::bipolar.
  static constexpr uint32_t kBipolar = 1u << 28;
  // In `count`: the node may show glossy senders' radiance
  // (PageView::glossy, storage/codecs/glossy_pages.h) besides its SH's.
  static constexpr uint32_t kGlossy = 1u << 27;
  // In `count`: a proxy, the view's copy of a child in another page (the
  // summary its parent's page stores, equal to that page's root); its one
  // link (children[0]) is the child itself. Seen, culled or
  // splatted as it is; opening it needs the child's page (PagePins).
  static constexpr uint32_t kProxy = 1u << 26;
  static constexpr uint32_t kCountMask = kProxy - 1;

  float cx, cy, cz, radius;  // bounding sphere
  float ax, ay, az;          // normal cone axis (unit)
  float cone_cos;            // cos of the half angle beta; <= -1: normals every way
  float cone_sin;            // sin(beta)
  // cos(kCoplanarAngle - beta) when beta < kCoplanarAngle, else 2: the node
  // is coplanar with a receiver of normal n when dot(axis, n) exceeds it.
  float coplanar_cos;
  uint32_t first;  // leaf: first surfel
  uint32_t count;  // flags | child count (internal) or surfel count (leaf)
  tree::NodeRef children[tree::Node::kMaxChildren];  // internal: its children

  bool leaf() const { return count & kLeaf; }
  bool narrow() const { return count & kNarrow; }
  bool invisible() const { return count & kInvisible; }
  bool bipolar() const { return count & kBipolar; }
  bool glossy() const { return count & kGlossy; }
  bool proxy() const { return count & kProxy; }
  uint32_t size() const { return count & kCountMask; }
};
static_assert(sizeof(HotNode) == 64, "one cache line");

// What a narrow-cone node shows (node_appearance.h), read only when it is
// splatted: its area-weighted mean radiance, area and mean normal. Wide
// and bipolar nodes use only its area. Half a line: the cone's fan
// (FanCone) is not kept but derived from HotNode::cone_cos when the node is
// splatted (fan_cone(), one square root), which halves the looks of a
// cached page (docs/out-of-core.md).
struct alignas(32) NodeLook {
  float r, g, b;  // >= 0; all 0 when the payload shows nothing
  float area;
  float mx, my, mz;  // area-weighted mean normal (node_appearance.h)
  // A wide, non-bipolar node's entry in PageView::full, else kNoFull: kept
  // in the look, whose line the walk prefetches with the node's, so that a
  // wide splat reaches its WideNode without another array's cache miss.
  uint32_t full = kNoFull;
  static constexpr uint32_t kNoFull = ~0u;
};
static_assert(sizeof(NodeLook) == 32, "half a cache line: two looks never straddle one");

// What the walk reads of a leaf's surfel (CutWalker::leaf_surfels): the
// decoded position, radius, normal and radiance of a tree Surfel, exactly,
// without its albedo, emission and gloss, which a gather never reads
// (40 bytes instead of 80). A page that carries its view keeps its
// surfels only here.
struct LeafSurfel {
  Imath::V3f position;
  float radius = 0.f;
  Imath::V3f normal;
  Imath::C3f radiance;
  // As Surfel::area(), to the bit.
  float area() const { return 3.14159265358979f * radius * radius; }
};
static_assert(sizeof(LeafSurfel) == 40);

// What a wide splat reads of its node (node_appearance.h): the cone, area
// and SH payload of a tree::Node, without its bounds and links, which the
// HotNode holds (164 bytes instead of 208).
struct WideNode {
  Imath::V3f cone_axis;
  float cone_cos = -1.f;
  float area = 0.f;
  sh::ShRgb radiance_sh;
  sh::Sh9 coverage_sh{};
};
inline WideNode wide_node(const tree::Node& n) { return {n.cone_axis, n.cone_cos, n.area, n.radiance_sh, n.coverage_sh}; }

// A page's view is one allocation: its header line (PageView), then its
// nodes, looks, leaf surfels, full nodes and bipolar faces, then the rarely read rest
// (PageView::Cold). With pages of a few levels (formats V4/V5) a walk
// enters a new view every few nodes, and each entry waited for the view's
// header and its first node one after the other when they lived in
// separate allocations; here the header and node 0 (the page's root, the
// node a walk enters by) share one 128-byte-aligned pair of lines, which
// the core fetches together, and the nodes' address needs no load at all
// (nodes() is the line after the header). The header is 64 bytes; build()
// allocates it 128-byte aligned.
struct alignas(64) PageView {
  uint32_t id = 0;
  uint32_t page_nodes = 0;  // nodes of the page; proxies follow them
  uint32_t node_count = 0;  // page nodes + proxies
  uint32_t bipolar_count = 0;
  // Per node; meaningful for narrow ones.
  const NodeLook* looks = nullptr;
  // The cone and payload of the nodes whose SH payload a splat reads (wide
  // cones that are not bipolar): full_nodes[looks[i].full]. The rest need
  // only the nodes and looks, so a page that carries its view need not
  // keep its nodes.
  const WideNode* full_nodes = nullptr;
  // Bipolar nodes' faces; bipolar_index[i] (null when the page has none) is
  // node i's entry.
  const Bipolar* bipolar = nullptr;
  const uint32_t* bipolar_index = nullptr;
  // The page's glossy radiance (owned through cold->glossy), or null.
  const storage::GlossyNodes* glossy = nullptr;
  struct Cold;
  const Cold* cold = nullptr;

  // What only building, checking and accounting read.
  struct Cold {
    std::shared_ptr<const storage::GlossyNodes> glossy;
    size_t surfel_count = 0;
    size_t bytes = 0;  // the whole allocation's heap block (tree::heap_block_bytes)
    uint32_t full_count = 0;
    // Node 0's DC radiance and coverage (radiance_sh[0], coverage_sh[0]):
    // a tree root's mean radiance, kept apart so that node 0 needs no full
    // copy (most pages' node 0 is narrow).
    float node0_dc[4] = {0.f, 0.f, 0.f, 0.f};
  };

  // The page's nodes (indices below page_nodes), then one proxy per child
  // in another page that the page describes exactly (tree::Page::links):
  // a walk decides on such a child without loading its page. They start on
  // the line after the header.
  const HotNode* node_data() const { return reinterpret_cast<const HotNode*>(this + 1); }
  std::span<const HotNode> nodes() const { return {node_data(), node_count}; }

  // The page's leaf surfels (Page::surfels, in their order), after the looks.
  const LeafSurfel* surfels() const { return reinterpret_cast<const LeafSurfel*>(looks + node_count); }

  // The WideNode of view node `i`, for the nodes `full_nodes` keeps; else null.
  const WideNode* full_node(uint32_t i) const {
    return i < node_count && looks[i].full != NodeLook::kNoFull ? full_nodes + looks[i].full : nullptr;
  }

  // Frees a view made by build().
  struct Free {
    void operator()(PageView* v) const;
  };
  using Ptr = std::unique_ptr<PageView, Free>;

  // Builds the view of `page`; throws CorruptionError for a child count
  // above tree::Node::kMaxChildren, a link to a missing node of the same
  // page or a leaf's surfel range outside the page.
  static Ptr build(const tree::Page& page);

  PageView(const PageView&) = delete;
  PageView& operator=(const PageView&) = delete;
  size_t memory_bytes() const { return cold->bytes; }
  // Whether `page` could be the page this view was built from.
  bool matches(const tree::Page& page) const {
    return page.id == id && page.nodes.size() == page_nodes && page.nodes.size() + page.links.size() == node_count &&
           page.surfels.size() == cold->surfel_count;
  }

 private:
  PageView() = default;
};
static_assert(sizeof(PageView) == 64, "one line; node 0 is the next, in the same 128-byte pair");

// Builds `page`'s view and attaches it to the page, so that every Gatherer
// reuses it for as long as the page cache keeps the page, and the cache's
// budget pays for it. The view holds what a gather reads of the page's
// nodes, links and surfels, so the page drops them (Page::nodes,
// Page::links and Page::surfels come back empty, their memory freed): a
// page in the cache costs its view, not two copies of its content. Install it as the
// PageSetReader's page decorator (storage/pages/page_set.h) of readers
// whose pages only gathers read. Throws as PageView's constructor.
void attach_view(tree::Page& page);

// Views by page id: the one attached to the page (attach_view) or else built
// on first use, owned here or, with a shared
// GatherCache, by the cache (then this only keeps pointers to them).
// trim() drops the views it owns once they exceed the byte budget; it must
// only be called while no view is in use (between receivers or batches).
class PageViews {
 public:
  explicit PageViews(GatherCache::Impl* shared = nullptr, size_t budget_bytes = size_t(64) << 20)
      : shared_(shared), budget_(budget_bytes) {}

  const PageView& get(const tree::Page& page);
  void trim() {
    if (bytes_ > budget_) clear();
  }
  void clear();
  size_t bytes() const { return bytes_; }
  size_t built() const { return built_; }

 private:
  static constexpr uint32_t kDenseIds = 1u << 22;
  const PageView*& slot(uint32_t id);

  GatherCache::Impl* shared_;
  std::vector<const PageView*> dense_;  // ids below kDenseIds
  std::unordered_map<uint32_t, const PageView*> sparse_;
  std::vector<PageView::Ptr> owned_;
  size_t budget_;
  size_t bytes_ = 0;  // of owned_
  size_t built_ = 0;
};

}  // namespace pbgi::gather

namespace pbgi {

// The shared store behind a GatherCache: views by page id under a mutex.
// Views are immutable once built and never freed while the cache lives, so
// Gatherers keep plain pointers to them.
struct GatherCache::Impl {
  const gather::PageView& get(const tree::Page& page);
  mutable std::mutex mutex;
  std::unordered_map<uint32_t, gather::PageView::Ptr> views;
  // Replaced views (a page id whose content changed): kept alive, since
  // other threads may still point to them.
  std::vector<gather::PageView::Ptr> retired;
  size_t bytes = 0;
};

}  // namespace pbgi
