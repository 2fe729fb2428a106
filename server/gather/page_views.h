// The gather's own compact view of a tree page: what the traversal's hot
// loop reads per node (bounding sphere, normal cone, child links) in half
// a cache line (PackedNode), and in an array of its own what a node shows
// when it is splatted (PackedLook, a quarter line), apart from the cone and
// SH payload that only wide-cone splats read (WideNode). Cone axes, looks
// and leaf surfels are kept in fixed-point codes (below, view_codes.h)
// and decoded as the walk reads them: the
// page cache's budget is set in bytes on disk, and a view of float records
// cost 4.7 times a page's bytes on disk, so the cache held a fifth of the
// pages its budget named (docs/out-of-core.md). Building a view costs about one pass over
// the page's nodes; views are cached and reused by every receiver.
//
// The walk is bound by memory latency (perf on bench_gather and pbgi
// bench, docs/gather.md section 12). The child links live in the node's
// own record: in an array of their own, loading them was a cache miss of
// its own (a third of push_children's time). Nodes stay dense in the
// depth-first pre-order of the page: a node's first child, popped next, is
// the following record. A node's look is prefetched when the node is
// pushed, so that it is on its way when the node is splatted.
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
#include "server/gather/view_codes.h"
#include "storage/codecs/glossy_pages.h"
#include "storage/tree/node.h"
#include "storage/tree/payload_rounding.h"

#include <algorithm>
#include <cmath>
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

// A node as the walk reads it, decoded from the view's PackedNode
// (PageView::node()): bounding sphere, normal cone with its sine and
// coplanarity bound, flags and counts, and the link to its children, its
// first surfel (leaf) or the child it stands for (proxy).
struct HotNode {
  static constexpr uint32_t kLeaf = 1u << 31;       // in `count`: a leaf
  static constexpr uint32_t kInvisible = 1u << 30;  // in `count`: no area or NaN bounds
  // In `count`: a narrow normal cone (node_appearance.h); its appearance
  // comes from PageView::look() without touching the tree::Node.
  static constexpr uint32_t kNarrow = 1u << 29;
  // In `count`: a wide cone whose normals form two opposite sheets (both
  // faces of a thin wall, node_appearance.h); its appearance comes from
  // PageView::bipolar.
  static constexpr uint32_t kBipolar = 1u << 28;
  // In `count`: the node may show glossy senders' radiance
  // (PageView::glossy(), storage/codecs/glossy_pages.h) besides its SH's.
  static constexpr uint32_t kGlossy = 1u << 27;
  // In `count`: a proxy, the view's copy of a child in another page (the
  // summary its parent's page stores, equal to that page's root); its link
  // is the child itself (PageView::proxy_target). Seen, culled or
  // splatted as it is; opening it needs the child's page (PagePins).
  static constexpr uint32_t kProxy = 1u << 26;
  static constexpr uint32_t kCountMask = kProxy - 1;

  float cx, cy, cz, radius;  // bounding sphere (contains the tree node's)
  float ax, ay, az;          // normal cone axis (unit)
  float cone_cos;            // cos of the half angle beta; <= -1: normals every way
  float cone_sin;            // sin(beta)
  // cos(kCoplanarAngle - beta) when beta < kCoplanarAngle, else 2: the node
  // is coplanar with a receiver of normal n when dot(axis, n) exceeds it.
  float coplanar_cos;
  uint32_t count;  // flags | child count (internal) or surfel count (leaf)
  uint32_t link;   // see PackedNode::link

  bool leaf() const { return count & kLeaf; }
  bool narrow() const { return count & kNarrow; }
  bool invisible() const { return count & kInvisible; }
  bool bipolar() const { return count & kBipolar; }
  bool glossy() const { return count & kGlossy; }
  bool proxy() const { return count & kProxy; }
  uint32_t size() const { return count & kCountMask; }
  uint32_t first() const { return link; }  // leaf: its first surfel in the view
};

// A node as the view keeps it: half a cache line. Bounds and cone are the
// node's floats; the axis is 16-bit fixed point per coordinate (within
// 2.6e-5 of the node's, not renormalized: with an octahedral code, the
// division normalizing it held a fifth of walk_receiver's profile samples),
// and the cone is not widened by that (a cull
// decided by 3e-5 rad of a normal cone concerns light from within 3e-5 rad
// of grazing). Flags and child or surfel count share 16 bits: 6 bits of
// HotNode flags, 10 of count; a view with a leaf of more surfels
// (kWideCounts) keeps every leaf's first surfel and count in refs. Every
// code depends on the node alone, not on its page: a node decodes to the
// same bits in any page layout, as the proxy of a linked child and as its
// page's root. The cone's sine and coplanarity bound are derived when the
// node is decoded.
struct alignas(32) PackedNode {
  static constexpr uint32_t kMaxCount = 1023;
  float center[3];
  float radius;
  int16_t axis[3];  // x 32767, rounded
  uint16_t count;   // HotNode::count's flags >> 16 | its count (<= kMaxCount)
  float cone_cos;   // as HotNode::cone_cos
  // Leaf: its first surfel (kWideCounts: its {first, count} in refs).
  // Proxy: its target in PageView::refs. Internal: child c in bits
  // 16c..16c+15, a view node below 0x8000, else refs[slot - 0x8000] (a
  // child in another page that has no proxy); in a view of kWideLinks,
  // refs[link + c].
  uint32_t link;
};
static_assert(sizeof(PackedNode) == 32, "two nodes a cache line");

// What a narrow-cone node shows (node_appearance.h), decoded from its
// PackedLook when it is splatted: its area-weighted mean radiance, area
// and mean normal.
struct NodeLook {
  float r = 0.f, g = 0.f, b = 0.f;  // >= 0; all 0 when the payload shows nothing
  float area = 0.f;
  float mx = 0.f, my = 0.f, mz = 0.f;  // area-weighted mean normal (node_appearance.h)
};

// A node's look as the view keeps it, read only when the node is
// splatted: a quarter line. Every node has its area; a narrow node its mean
// radiance (Rgb48) and mean normal (16-bit fixed point: its length matters,
// node_appearance.h); a wide node the index of its WideNode, a bipolar one
// of its Bipolar faces (in `extra`'s first four bytes).
struct alignas(16) PackedLook {
  float area = 0.f;
  Rgb48 radiance;
  uint16_t extra[3] = {0, 0, 0};
  uint32_t index() const { return uint32_t(extra[0]) | uint32_t(extra[1]) << 16; }
};
static_assert(sizeof(PackedLook) == 16);

// What the walk reads of a leaf's surfel (CutWalker::leaf_surfels): its
// position, radius, normal and radiance, without its albedo, emission and
// gloss, which a gather never reads. Decoded from a PackedSurfel.
struct LeafSurfel {
  Imath::V3f position;
  float radius = 0.f;
  Imath::V3f normal;
  Imath::C3f radiance;
  float area() const { return 3.14159265358979f * radius * radius; }
};

// A leaf surfel as the view keeps it (20 bytes): position and radius in
// 16-bit fixed point of its leaf's decoded sphere (within R / 65534 and
// R / 131070), normal in 16-bit fixed point per coordinate (within 2.6e-5,
// not renormalized: an octahedral code's normalization cost 4% of a
// gather), radiance in Rgb48 (exact for the RGB9E5 radiance of pages on
// disk).
struct PackedSurfel {
  int16_t offset[3];
  uint16_t radius;
  int16_t normal[3];
  Rgb48 radiance;
};
static_assert(sizeof(PackedSurfel) == 20);

// What a wide splat reads of its node (node_appearance.h): the cone, area
// and SH payload of a tree::Node, without its bounds and links, which the
// PackedNode holds (164 bytes instead of 208). Decoded from a PackedWide.
struct WideNode {
  Imath::V3f cone_axis;
  float cone_cos = -1.f;
  float area = 0.f;
  sh::ShRgb radiance_sh;
  sh::Sh9 coverage_sh{};
};
inline WideNode wide_node(const tree::Node& n) {
  return {n.cone_axis, n.cone_cos, n.area, n.radiance_sh, n.coverage_sh};
}

// A WideNode as the view keeps it (96 bytes): its payload in the rounded
// form of the tree's payloads (storage/tree/payload_rounding.h), exactly.
// A view whose wide nodes' payloads are not all of that form (a tree built
// without rounding) keeps WideNodes instead (PageView::kFloatWide).
struct PackedWide {
  float cone_axis[3];
  float cone_cos;
  float area;
  uint8_t payload[tree::kRoundedPayloadBytes];
};
static_assert(sizeof(PackedWide) == 96);

// A page's view is one allocation: its header line (PageView), then its
// packed nodes, looks, leaf surfels, child references, full nodes and
// bipolar faces, then the rarely read rest (node 0's DC terms and, for a
// page with glossy senders, the pointer to their radiance). With pages of
// a few levels (formats V4-V7) a walk enters a new view every few nodes,
// and each entry waited for the view's header and its first node one after
// the other when they lived in separate allocations; here the header and
// nodes 0 and 1 (the page's root, the node a walk enters by, and its first
// child) share one 128-byte-aligned pair of lines, which the core fetches
// together. The header is 64 bytes; build() allocates it 128-byte aligned.
//
// A view is the page's attachment (attach_view): what a page set reader
// with the view as its decorator caches and charges, instead of a Page
// record holding a separate attachment (~150 bytes a page fewer).
struct alignas(64) PageView final : tree::PageAttachment {
  // In `flags`: children are pairs in refs (a view too large for 15-bit
  // slots: PackedNode::link).
  static constexpr uint32_t kWideLinks = 1u;
  // In `flags`: full_at holds WideNodes, not PackedWides.
  static constexpr uint32_t kFloatWide = 2u;
  // In `flags`: a leaf holds more than PackedNode::kMaxCount surfels; every
  // leaf's first surfel and count are in refs ({page = first, index = count}).
  static constexpr uint32_t kWideCounts = 4u;

  uint32_t id = 0;
  uint32_t page_nodes = 0;  // nodes of the page; proxies follow them
  uint32_t node_count = 0;  // page nodes + proxies
  uint32_t flags = 0;
  // Byte offsets from `this` of the parts after the nodes.
  uint32_t looks_at = 0, surfels_at = 0, refs_at = 0, full_at = 0, bipolar_at = 0;
  uint32_t surfel_count = 0, full_count = 0, bipolar_count = 0;
  // memory_bytes(): the allocation's heap block (tree::heap_block_bytes),
  // the glossy radiance's bytes and, for an attached view, its
  // shared_ptr's control block.
  uint32_t charged = 0;
  // Byte offset from `this` of the page's glossy radiance (a GlossyPtr),
  // 0 when the page shows none: most pages keep no pointer for it.
  uint32_t glossy_at = 0;
  using GlossyPtr = std::shared_ptr<const storage::GlossyNodes>;

  // The page's nodes (indices below page_nodes), then one proxy per child
  // in another page that the page describes exactly (tree::Page::links):
  // a walk decides on such a child without loading its page. They start on
  // the line after the header.
  const PackedNode* packed_nodes() const { return reinterpret_cast<const PackedNode*>(this + 1); }
  const PackedLook* looks() const { return at<PackedLook>(looks_at); }
  const PackedSurfel* surfels() const { return at<PackedSurfel>(surfels_at); }
  const tree::NodeRef* refs() const { return at<tree::NodeRef>(refs_at); }
  const Bipolar* bipolar() const { return at<Bipolar>(bipolar_at); }
  const storage::GlossyNodes* glossy() const { return glossy_at ? at<GlossyPtr>(glossy_at)->get() : nullptr; }
  // Node 0's DC radiance and coverage (radiance_sh[0], coverage_sh[0]): a
  // tree root's mean radiance, kept apart so that node 0 needs no full
  // copy (most pages' node 0 is narrow). After the bipolar faces.
  const float* node0_dc() const { return at<float>(node0_dc_at(bipolar_at, bipolar_count)); }
  static size_t node0_dc_at(size_t bipolar_at, size_t bipolar_count) {
    return (bipolar_at + bipolar_count * sizeof(Bipolar) + alignof(float) - 1) / alignof(float) * alignof(float);
  }

  // Node `i` (< node_count) decoded.
  HotNode node(uint32_t i) const {
    const PackedNode& p = packed_nodes()[i];
    HotNode h;
    h.cx = p.center[0];
    h.cy = p.center[1];
    h.cz = p.center[2];
    h.radius = p.radius;
    constexpr float kSnorm = 1.f / 32767.f;
    h.ax = float(p.axis[0]) * kSnorm;
    h.ay = float(p.axis[1]) * kSnorm;
    h.az = float(p.axis[2]) * kSnorm;
    h.cone_cos = p.cone_cos;
    const bool cone = p.cone_cos > -1.f;
    h.cone_sin = cone ? std::sqrt(std::max(0.f, 1.f - p.cone_cos * p.cone_cos)) : 1.f;
    // angle(axis, n) + beta < kCoplanarAngle  <=>  dot(axis, n) > cos(kCoplanarAngle - beta)
    //   = cos(kCoplanarAngle) cos(beta) + sin(kCoplanarAngle) sin(beta).
    h.coplanar_cos = cone && p.cone_cos > kCoplanarCos ? kCoplanarCos * p.cone_cos + kCoplanarSin * h.cone_sin : 2.f;
    h.count = uint32_t(p.count & 0xfc00u) << 16 | (p.count & 0x3ffu);
    h.link = p.link;
    if ((flags & kWideCounts) && h.leaf()) {
      const tree::NodeRef& r = refs()[p.link];
      h.link = r.page;
      h.count = (h.count & ~HotNode::kCountMask) | r.index;
    }
    return h;
  }
  // Child `c` of internal node `h` of this view.
  tree::NodeRef child(const HotNode& h, uint32_t c) const {
    if (flags & kWideLinks) return refs()[h.link + c];
    const uint32_t slot = (h.link >> (16 * c)) & 0xffffu;
    return slot < 0x8000u ? tree::NodeRef{id, slot} : refs()[slot - 0x8000u];
  }
  // The child proxy `h` stands for.
  tree::NodeRef proxy_target(const HotNode& h) const { return refs()[h.link]; }
  // Narrow node i's look.
  NodeLook look(uint32_t i) const;
  float look_area(uint32_t i) const { return looks()[i].area; }
  // The WideNode of view node `i` into `out`, for the nodes the view keeps
  // one of (wide cones that are not bipolar); else false.
  bool full_node(uint32_t i, WideNode& out) const;
  // Bytes of the view's wide nodes.
  size_t full_bytes() const { return bipolar_at - full_at; }
  // Bipolar node i's faces.
  const Bipolar& bipolar_of(uint32_t i) const { return bipolar()[looks()[i].index()]; }
  // Surfel `i` of the view, of leaf `leaf` (decoded).
  LeafSurfel surfel(const HotNode& leaf, uint32_t i) const {
    const PackedSurfel& p = surfels()[i];
    const float step = leaf.radius * (1.f / 32767.f);
    constexpr float kSnorm = 1.f / 32767.f;
    LeafSurfel s;
    s.position = Imath::V3f(leaf.cx + float(p.offset[0]) * step, leaf.cy + float(p.offset[1]) * step,
                            leaf.cz + float(p.offset[2]) * step);
    s.radius = float(p.radius) * (leaf.radius * (1.f / 65535.f));
    s.normal = Imath::V3f(float(p.normal[0]) * kSnorm, float(p.normal[1]) * kSnorm, float(p.normal[2]) * kSnorm);
    s.radiance = decode_rgb48(p.radiance);
    return s;
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
  // Bytes of the scratch arrays the calling thread keeps between build()s
  // (reused from view to view; those a large page grew are freed after it).
  static size_t thread_scratch_bytes();

  PageView(const PageView&) = delete;
  PageView& operator=(const PageView&) = delete;
  size_t memory_bytes() const override { return charged; }
  // Whether `page` could be the page this view was built from.
  bool matches(const tree::Page& page) const {
    return page.id == id && page.nodes.size() == page_nodes && page.nodes.size() + page.links.size() == node_count &&
           page.surfels.size() == surfel_count;
  }

 private:
  PageView() = default;
  template <class T>
  const T* at(uint32_t offset) const {
    return reinterpret_cast<const T*>(reinterpret_cast<const std::byte*>(this) + offset);
  }
  static constexpr float kCoplanarCos = 0.99980000666657776f;   // cos(kCoplanarAngle)
  static constexpr float kCoplanarSin = 0.019998666693333080f;  // sin(kCoplanarAngle)
};
static_assert(sizeof(PageView) == 64, "one line; nodes 0 and 1 are the next, in the same 128-byte pair");

// Builds `page`'s view and attaches it to the page: installed as a
// PageSetReader's page decorator (storage/pages/page_set.h), the reader
// caches the view alone, every Gatherer reuses it for as long as the page
// cache keeps it, and the cache's budget pays for it. The view holds what
// a gather reads of the page's nodes, links and surfels, so the page drops
// them (Page::nodes, Page::links and Page::surfels come back empty; the
// reader reuses their memory for the next page it decodes). Throws as
// PageView::build.
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
