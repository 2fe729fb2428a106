#include "server/gather/page_views.h"

#include "common/errors.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <malloc.h>
#include <memory>
#include <new>
#include <string>
#include <type_traits>

namespace pbgi::gather {

namespace {

bool finite(const Imath::V3f& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

std::string where(const tree::Page& page, size_t node) {
  return "tree page " + std::to_string(page.id) + " node " + std::to_string(node);
}

}  // namespace

namespace {

// What build() derives of a node before it is packed.
struct NodeParts {
  Imath::V3f center{0.f};
  float radius = 0.f;
  Imath::V3f axis{0.f};
  float cone_cos = -2.f;
  uint32_t count = 0;
  uint32_t first = 0;                                // leaf
  tree::NodeRef children[tree::Node::kMaxChildren];  // internal; proxy: children[0]
  NodeLook look;                                     // narrow: all of it; else its area
  uint32_t index = 0;                                // wide: full entry; bipolar: its faces
};

// What build() derives from a page before it lays the view out in one
// allocation.
struct ViewParts {
  std::vector<NodeParts> nodes;
  std::vector<WideNode> full;
  std::vector<Bipolar> bipolar;
  float node0_dc[4] = {0.f, 0.f, 0.f, 0.f};

  // Fills nodes[i] (and the bipolar or full entry) from `n`; returns the
  // HotNode flags.
  uint32_t describe(const tree::Node& n, size_t i, const storage::GlossyNodes* glossy, size_t page_nodes);
};

uint32_t ViewParts::describe(const tree::Node& n, size_t i, const storage::GlossyNodes* glossy, size_t page_nodes) {
  NodeParts& h = nodes[i];
  h.center = n.center;
  h.radius = n.radius;
  h.axis = n.cone_axis;
  const bool cone = n.cone_cos > -1.f;  // also false for NaN
  h.cone_cos = cone ? std::min(n.cone_cos, 1.f) : -2.f;

  uint32_t flags = 0;
  NodeLook& look = h.look;
  look.area = n.area;
  if (n.cone_cos >= kNarrowConeCos) {
    // The flat model of node_appearance(): DC ratio and the cone's fan.
    flags |= HotNode::kNarrow;
    const float c0 = n.coverage_sh[0];
    if (c0 > 0.f) {
      const float inv = 1.f / c0;
      const Imath::C3f L(std::max(0.f, n.radiance_sh.r[0] * inv), std::max(0.f, n.radiance_sh.g[0] * inv),
                         std::max(0.f, n.radiance_sh.b[0] * inv));
      if (std::isfinite(L.x) && std::isfinite(L.y) && std::isfinite(L.z)) {
        look.r = L.x;
        look.g = L.y;
        look.b = L.z;
        const Imath::V3f m = mean_normal(n);
        look.mx = m.x;
        look.my = m.y;
        look.mz = m.z;
      } else {
        look.area = 0.f;  // shows nothing
      }
    } else {
      look.area = 0.f;
    }
  } else {
    Bipolar b;
    if (fit_bipolar(n, b)) {
      flags |= HotNode::kBipolar;
      h.index = uint32_t(bipolar.size());
      bipolar.push_back(b);
    }
  }
  if (glossy && i < page_nodes && glossy->glossy(static_cast<uint32_t>(i))) flags |= HotNode::kGlossy;
  if (i == 0) {
    node0_dc[0] = n.radiance_sh.r[0];
    node0_dc[1] = n.radiance_sh.g[0];
    node0_dc[2] = n.radiance_sh.b[0];
    node0_dc[3] = n.coverage_sh[0];
  }
  if (!(flags & (HotNode::kNarrow | HotNode::kBipolar))) {
    h.index = uint32_t(full.size());
    full.push_back(wide_node(n));
  }
  // Nothing to see: no area, or NaN/negative/infinite bounds.
  if (!(n.area > 0.f) || !(n.radius >= 0.f) || !std::isfinite(n.radius) || !finite(n.center)) {
    flags |= HotNode::kInvisible;
  }
  return flags;
}

// Fills `parts` (its arrays reused: a view is built on every page cache
// miss, and allocating them was a tenth of that).
void derive_parts(const tree::Page& page, ViewParts& parts) {
  const size_t n = page.nodes.size();
  parts.nodes.assign(n + page.links.size(), NodeParts{});
  parts.full.clear();
  parts.bipolar.clear();
  std::fill(parts.node0_dc, parts.node0_dc + 4, 0.f);
  const storage::GlossyNodes* glossy = page.glossy.get();
  for (size_t i = 0; i < n; ++i) {
    const tree::Node& node = page.nodes[i];
    NodeParts& h = parts.nodes[i];
    const uint32_t flags = parts.describe(node, i, glossy, n);
    if (node.is_leaf()) {
      const uint64_t end = uint64_t(node.first_surfel) + node.surfel_count;
      if (end > page.surfels.size()) {
        throw CorruptionError("tree page " + std::to_string(page.id) + " leaf " + std::to_string(i) + ": surfels [" +
                              std::to_string(node.first_surfel) + ", " + std::to_string(end) + ") outside the page's " +
                              std::to_string(page.surfels.size()));
      }
      if (node.surfel_count > HotNode::kCountMask) {
        throw CorruptionError(where(page, i) + ": " + std::to_string(node.surfel_count) + " surfels in one leaf");
      }
      h.first = node.first_surfel;
      h.count = flags | HotNode::kLeaf | node.surfel_count;
    } else {
      if (node.child_count > tree::Node::kMaxChildren) {
        throw CorruptionError(where(page, i) + ": child_count " + std::to_string(node.child_count) + " exceeds " +
                              std::to_string(tree::Node::kMaxChildren));
      }
      h.count = flags | node.child_count;
      for (uint32_t c = 0; c < node.child_count; ++c) {
        const tree::NodeRef ref = node.children[c];
        if (ref.page == page.id && ref.index >= n) {
          throw CorruptionError(where(page, i) + ": child link to page " + std::to_string(ref.page) + " node " +
                                std::to_string(ref.index) + " is out of range (" + std::to_string(n) + " nodes)");
        }
        h.children[c] = ref;
      }
    }
  }
  // Proxies: each child in another page becomes a node of this view, seen
  // through the summary this page stores of it, whose one link is the
  // child's own page root. The parent's link is turned to the proxy.
  for (size_t k = 0; k < page.links.size(); ++k) {
    const tree::PageLink& l = page.links[k];
    const size_t i = n + k;
    if (l.parent >= n || l.slot >= page.nodes[l.parent].child_count ||
        page.nodes[l.parent].children[l.slot] != l.summary.children[0]) {
      throw CorruptionError(where(page, l.parent) + ": link " + std::to_string(k) +
                            " does not match the node's child " + std::to_string(l.slot));
    }
    NodeParts& h = parts.nodes[i];
    h.count = parts.describe(l.summary, i, glossy, n) | HotNode::kProxy | 1u;
    h.children[0] = l.summary.children[0];
    parts.nodes[l.parent].children[l.slot] = {page.id, uint32_t(i)};
  }
}

// x in [-1, 1] (clamped; NaN -> 0) to [-32767, 32767] and x in [0, 1] to
// [0, 65535], rounded to nearest (storage/format/packed_values.h's codes,
// without their library call: a view is built on every page cache miss).
int16_t snorm16(float x) {
  const float t = std::clamp(x, -1.f, 1.f) * 32767.f;
  return t >= 0.f ? int16_t(round_half_up(t)) : t < 0.f ? int16_t(-int(round_half_up(-t))) : int16_t(0);
}
uint16_t unorm16(float x) {
  const float t = std::clamp(x, 0.f, 1.f) * 65535.f;
  return t >= 0.f ? uint16_t(round_half_up(t)) : uint16_t(0);
}

// Packs the nodes. Children in other pages without proxies (and every
// child of a kWideLinks view) go to `refs`.
void pack_nodes(const ViewParts& parts, const tree::Page& page, PageView& view, std::vector<PackedNode>& packed,
                std::vector<tree::NodeRef>& refs) {
  const size_t count = parts.nodes.size();
  packed.resize(count);
  // 15-bit slots name the view's own nodes and refs; beyond that every
  // child is a pair in refs.
  size_t external = 0;
  for (const NodeParts& h : parts.nodes) {
    if ((h.count & (HotNode::kLeaf | HotNode::kProxy)) == 0) {
      for (uint32_t c = 0; c < (h.count & HotNode::kCountMask); ++c) external += h.children[c].page != page.id;
    } else if (h.count & HotNode::kProxy) {
      ++external;
    }
  }
  if (count > 0x8000u || external > 0x8000u) view.flags |= PageView::kWideLinks;
  const bool wide = view.flags & PageView::kWideLinks;
  for (const NodeParts& h : parts.nodes) {
    if ((h.count & HotNode::kLeaf) && (h.count & HotNode::kCountMask) > PackedNode::kMaxCount) {
      view.flags |= PageView::kWideCounts;
    }
  }
  const bool wide_counts = view.flags & PageView::kWideCounts;
  for (size_t i = 0; i < count; ++i) {
    const NodeParts& h = parts.nodes[i];
    PackedNode& p = packed[i];
    p.center[0] = h.center.x;
    p.center[1] = h.center.y;
    p.center[2] = h.center.z;
    p.radius = h.radius;
    for (int a = 0; a < 3; ++a) p.axis[a] = snorm16(h.axis[a]);
    p.cone_cos = h.cone_cos;
    const uint32_t size = h.count & HotNode::kCountMask;
    p.count = uint16_t((h.count & ~HotNode::kCountMask) >> 16 | std::min(size, PackedNode::kMaxCount));
    if ((h.count & HotNode::kLeaf) && wide_counts) {
      p.link = uint32_t(refs.size());
      refs.push_back({h.first, size});
    } else if (h.count & HotNode::kLeaf) {
      p.link = h.first;
    } else if (h.count & HotNode::kProxy) {
      p.link = uint32_t(refs.size());
      refs.push_back(h.children[0]);
    } else if (wide) {
      p.link = uint32_t(refs.size());
      refs.insert(refs.end(), h.children, h.children + tree::Node::kMaxChildren);
    } else {
      p.link = 0;
      for (uint32_t c = 0; c < (h.count & HotNode::kCountMask); ++c) {
        const tree::NodeRef ref = h.children[c];
        uint32_t slot = ref.index;
        if (ref.page != page.id) {
          slot = 0x8000u + uint32_t(refs.size());
          refs.push_back(ref);
        }
        p.link |= slot << (16 * c);
      }
    }
  }
}

PackedLook pack_look(const NodeParts& h) {
  PackedLook l;
  l.area = h.look.area;
  if (h.count & HotNode::kNarrow) {
    l.radiance = encode_rgb48(Imath::C3f(h.look.r, h.look.g, h.look.b));
    l.extra[0] = uint16_t(snorm16(h.look.mx));
    l.extra[1] = uint16_t(snorm16(h.look.my));
    l.extra[2] = uint16_t(snorm16(h.look.mz));
  } else {
    l.extra[0] = uint16_t(h.index);
    l.extra[1] = uint16_t(h.index >> 16);
  }
  return l;
}

// The surfels of leaf `leaf` in fixed point of its decoded sphere.
void pack_surfels(const tree::Page& page, const HotNode& leaf, PackedSurfel* out) {
  const Imath::V3f c(leaf.cx, leaf.cy, leaf.cz);
  const float r = leaf.radius;
  const float inv = r > 0.f ? 1.f / r : 0.f;
  for (uint32_t k = 0; k < leaf.size(); ++k) {
    const Surfel& s = page.surfels[leaf.first() + k];
    PackedSurfel& p = out[leaf.first() + k];
    for (int a = 0; a < 3; ++a) p.offset[a] = snorm16((s.position[a] - c[a]) * inv);
    p.radius = unorm16(s.radius * inv);
    for (int a = 0; a < 3; ++a) p.normal[a] = snorm16(s.normal[a]);
    p.radiance = encode_rgb48(s.radiance);
  }
}

// Byte offsets of a view's parts in its allocation.
constexpr size_t kViewAlign = 128;
size_t round_up(size_t n, size_t a) { return (n + a - 1) / a * a; }

template <class T>
T* copy_to(std::byte* base, size_t offset, const std::vector<T>& v) {
  T* out = reinterpret_cast<T*>(base + offset);
  std::uninitialized_copy(v.begin(), v.end(), out);
  return out;
}

}  // namespace

namespace {
// build()'s arrays, kept by each thread from view to view (a cache miss
// builds the view of a page of ~10 nodes; allocating them each time showed
// in its profile). A view of a large page (an in-memory tree is one page
// of all its nodes) grows them to its size: arrays above kMaxKeptBytes are
// freed when that view is built, so what a thread keeps between views, and
// the budget does not count, is at most 7 x 256 KiB.
struct ViewScratch {
  ViewParts parts;
  std::vector<tree::NodeRef> refs;
  std::vector<PackedNode> nodes;
  std::vector<PackedLook> looks;
  std::vector<PackedWide> packed_wide;

  static constexpr size_t kMaxKeptBytes = size_t(256) << 10;
  template <class T>
  static void trim(std::vector<T>& v) {
    if (v.capacity() * sizeof(T) > kMaxKeptBytes) std::vector<T>().swap(v);
  }
  template <class T>
  static size_t bytes_of(const std::vector<T>& v) {
    return v.capacity() * sizeof(T);
  }
  void trim() {
    trim(parts.nodes);
    trim(parts.full);
    trim(parts.bipolar);
    trim(refs);
    trim(nodes);
    trim(looks);
    trim(packed_wide);
  }
  size_t bytes() const {
    return bytes_of(parts.nodes) + bytes_of(parts.full) + bytes_of(parts.bipolar) + bytes_of(refs) + bytes_of(nodes) +
           bytes_of(looks) + bytes_of(packed_wide);
  }
};
thread_local ViewScratch view_scratch;

// Trims the thread's scratch when build() ends, also by an exception.
struct TrimScratchOnExit {
  ~TrimScratchOnExit() { view_scratch.trim(); }
};
}  // namespace

size_t PageView::thread_scratch_bytes() { return view_scratch.bytes(); }

PageView::Ptr PageView::build(const tree::Page& page) {
  ViewScratch& scratch = view_scratch;
  const TrimScratchOnExit trim_on_exit;
  ViewParts& parts = scratch.parts;
  derive_parts(page, parts);
  PageView header;
  header.id = page.id;
  header.page_nodes = uint32_t(page.nodes.size());
  header.node_count = uint32_t(parts.nodes.size());
  std::vector<tree::NodeRef>& refs = scratch.refs;
  refs.clear();
  std::vector<PackedNode>& nodes = scratch.nodes;
  pack_nodes(parts, page, header, nodes, refs);
  std::vector<PackedLook>& looks = scratch.looks;
  looks.resize(parts.nodes.size());
  for (size_t i = 0; i < looks.size(); ++i) looks[i] = pack_look(parts.nodes[i]);
  static_assert(std::is_trivially_destructible_v<PackedNode> && std::is_trivially_destructible_v<PackedLook> &&
                    std::is_trivially_destructible_v<WideNode> && std::is_trivially_destructible_v<Bipolar> &&
                    std::is_trivially_destructible_v<PackedSurfel> && std::is_trivially_destructible_v<tree::NodeRef>,
                "parts are copy-constructed into raw storage and never destroyed");
  // Wide nodes in the tree's rounded payload form when each round-trips
  // exactly (always, for trees built with rounded payloads).
  std::vector<PackedWide>& packed_wide = scratch.packed_wide;
  packed_wide.resize(parts.full.size());
  bool exact = true;
  for (size_t k = 0; k < parts.full.size() && exact; ++k) {
    const WideNode& w = parts.full[k];
    PackedWide& p = packed_wide[k];
    std::copy(&w.cone_axis.x, &w.cone_axis.x + 3, p.cone_axis);
    p.cone_cos = w.cone_cos;
    p.area = w.area;
    tree::Node probe;
    probe.radiance_sh = w.radiance_sh;
    probe.coverage_sh = w.coverage_sh;
    tree::write_rounded_payload(probe, p.payload);
    WideNode back;
    exact = tree::read_rounded_payload(p.payload, back.radiance_sh, back.coverage_sh) &&
            std::equal(&back.radiance_sh.r[0], &back.radiance_sh.r[0] + sh::kCoeffs, &w.radiance_sh.r[0]) &&
            std::equal(&back.radiance_sh.g[0], &back.radiance_sh.g[0] + sh::kCoeffs, &w.radiance_sh.g[0]) &&
            std::equal(&back.radiance_sh.b[0], &back.radiance_sh.b[0] + sh::kCoeffs, &w.radiance_sh.b[0]) &&
            std::equal(&back.coverage_sh[0], &back.coverage_sh[0] + sh::kCoeffs, &w.coverage_sh[0]);
  }
  if (!exact) header.flags |= kFloatWide;
  const size_t wide_bytes = exact ? sizeof(PackedWide) : sizeof(WideNode);
  // Header, nodes (half lines), looks (quarter lines), leaf surfels, refs,
  // wide nodes, bipolar faces, then node 0's DC terms and the glossy
  // radiance's pointer.
  const size_t nodes_at = sizeof(PageView);
  const size_t looks_at = nodes_at + nodes.size() * sizeof(PackedNode);
  const size_t surfels_at = looks_at + looks.size() * sizeof(PackedLook);
  const size_t refs_at = round_up(surfels_at + page.surfels.size() * sizeof(PackedSurfel), alignof(tree::NodeRef));
  const size_t full_at = round_up(refs_at + refs.size() * sizeof(tree::NodeRef), alignof(WideNode));
  const size_t bipolar_at = round_up(full_at + parts.full.size() * wide_bytes, alignof(Bipolar));
  const size_t dc_at = node0_dc_at(bipolar_at, parts.bipolar.size());
  const size_t glossy_at = page.glossy ? round_up(dc_at + 4 * sizeof(float), alignof(GlossyPtr)) : 0;
  const size_t end = glossy_at ? glossy_at + sizeof(GlossyPtr) : dc_at + 4 * sizeof(float);
  // What memory_bytes() may add to the block: the glossy radiance and a
  // control block; all of it must fit the header's 32 bits.
  if (end + 64 + page.glossy_bytes > std::numeric_limits<uint32_t>::max()) {
    throw CorruptionError("tree page " + std::to_string(page.id) + ": too large for a page view (" +
                          std::to_string(end + page.glossy_bytes) + " bytes)");
  }
  // posix_memalign, not aligned operator new: libstdc++'s rounds the size
  // up to the alignment (C11 aligned_alloc's rule), 64 bytes a view on
  // average; glibc's posix_memalign returns what precedes the aligned
  // start to the heap and takes only the block the size needs. jemalloc,
  // which pbgid links, rounds an aligned block up to a size class that is
  // a multiple of the alignment either way: the view is charged what the
  // allocator says the block holds (malloc_usable_size) plus a header
  // word, not glibc's block for the size asked, which fell up to 112
  // bytes short of jemalloc's.
  const size_t bytes = round_up(end, 16);

  void* memory = nullptr;
  if (posix_memalign(&memory, kViewAlign, bytes) != 0) throw std::bad_alloc();
  auto* base = static_cast<std::byte*>(memory);
  auto* view = new (base) PageView();
  Ptr owned(view);
  view->id = header.id;
  view->page_nodes = header.page_nodes;
  view->node_count = header.node_count;
  view->flags = header.flags;
  view->looks_at = uint32_t(looks_at);
  view->surfels_at = uint32_t(surfels_at);
  view->refs_at = uint32_t(refs_at);
  view->full_at = uint32_t(full_at);
  view->bipolar_at = uint32_t(bipolar_at);
  copy_to(base, nodes_at, nodes);
  copy_to(base, looks_at, looks);
  copy_to(base, refs_at, refs);
  if (exact) {
    copy_to(base, full_at, packed_wide);
  } else {
    copy_to(base, full_at, parts.full);
  }
  copy_to(base, bipolar_at, parts.bipolar);
  auto* surfels = reinterpret_cast<PackedSurfel*>(base + surfels_at);
  std::uninitialized_fill_n(surfels, page.surfels.size(), PackedSurfel{});
  for (uint32_t i = 0; i < view->page_nodes; ++i) {
    const HotNode h = view->node(i);
    if (h.leaf()) pack_surfels(page, h, surfels);
  }
  view->surfel_count = uint32_t(page.surfels.size());
  const size_t block = std::max(tree::heap_block_bytes(bytes), malloc_usable_size(memory) + sizeof(void*));
  if (block + 64 + page.glossy_bytes > std::numeric_limits<uint32_t>::max()) {
    throw CorruptionError("tree page " + std::to_string(page.id) + ": too large for a page view (" +
                          std::to_string(block + page.glossy_bytes) + " bytes)");
  }
  view->charged = uint32_t(block + page.glossy_bytes);
  view->full_count = uint32_t(parts.full.size());
  view->bipolar_count = uint32_t(parts.bipolar.size());
  std::copy(parts.node0_dc, parts.node0_dc + 4, reinterpret_cast<float*>(base + dc_at));
  if (glossy_at) {
    new (base + glossy_at) GlossyPtr(page.glossy);
    view->glossy_at = uint32_t(glossy_at);
  }
  return owned;
}

NodeLook PageView::look(uint32_t i) const {
  const PackedLook& p = looks()[i];
  NodeLook l;
  const Imath::C3f c = decode_rgb48(p.radiance);
  l.r = c.x;
  l.g = c.y;
  l.b = c.z;
  l.area = p.area;
  l.mx = float(int16_t(p.extra[0])) * (1.f / 32767.f);
  l.my = float(int16_t(p.extra[1])) * (1.f / 32767.f);
  l.mz = float(int16_t(p.extra[2])) * (1.f / 32767.f);
  return l;
}

bool PageView::full_node(uint32_t i, WideNode& out) const {
  if (i >= node_count || (packed_nodes()[i].count & (HotNode::kNarrow | HotNode::kBipolar))) return false;
  const uint32_t k = looks()[i].index();
  if (k >= full_count) return false;
  if (flags & kFloatWide) {
    out = at<WideNode>(full_at)[k];
    return true;
  }
  const PackedWide& p = at<PackedWide>(full_at)[k];
  out.cone_axis = Imath::V3f(p.cone_axis[0], p.cone_axis[1], p.cone_axis[2]);
  out.cone_cos = p.cone_cos;
  out.area = p.area;
  // Checked when the view was built: always true.
  return tree::read_rounded_payload(p.payload, out.radiance_sh, out.coverage_sh);
}

void PageView::Free::operator()(PageView* v) const {
  if (!v) return;
  if (v->glossy_at) {
    auto* glossy = reinterpret_cast<GlossyPtr*>(reinterpret_cast<std::byte*>(v) + v->glossy_at);
    glossy->~GlossyPtr();
  }
  v->~PageView();
  std::free(static_cast<void*>(v));
}

const PageView*& PageViews::slot(uint32_t id) {
  if (id < kDenseIds) {
    if (id >= dense_.size()) dense_.resize(std::max<size_t>(id + 1, 2 * dense_.size()), nullptr);
    return dense_[id];
  }
  return sparse_[id];
}

void attach_view(tree::Page& page) {
  PageView::Ptr view = PageView::build(page);
  // The control block the shared_ptr allocates for a pointer and its
  // (empty) deleter: a vtable pointer, two counts and the pointer.
  constexpr size_t kControlBlock = 2 * sizeof(void*) + 2 * sizeof(int);
  view->charged += uint32_t(tree::heap_block_bytes(kControlBlock));
  page.attachment = std::shared_ptr<const PageView>(view.release(), PageView::Free{});
  // Emptied: the reader reuses their memory for the next page it decodes
  // (storage/pages/page_set.h).
  page.nodes.clear();
  page.links.clear();
  page.surfels.clear();
}

const PageView& PageViews::get(const tree::Page& page) {
  // An attached view lives exactly as long as its page, which the caller
  // pins: it is never remembered in a slot, which would dangle once the
  // cache evicts the page.
  if (const auto* attached = dynamic_cast<const PageView*>(page.attachment.get())) return *attached;
  const PageView*& s = slot(page.id);
  if (s && s->matches(page)) return *s;
  if (shared_) {
    s = &shared_->get(page);
    return *s;
  }
  // A stale view of this id stays owned until the next clear(): the
  // caller's stack may still point to it.
  owned_.push_back(PageView::build(page));
  bytes_ += owned_.back()->memory_bytes();
  ++built_;
  s = owned_.back().get();
  return *s;
}

void PageViews::clear() {
  dense_.clear();
  sparse_.clear();
  owned_.clear();
  bytes_ = 0;
}

}  // namespace pbgi::gather

namespace pbgi {

const gather::PageView& GatherCache::Impl::get(const tree::Page& page) {
  std::lock_guard<std::mutex> lock(mutex);
  gather::PageView::Ptr& v = views[page.id];
  if (v && v->matches(page)) return *v;
  gather::PageView::Ptr built = gather::PageView::build(page);  // may throw: nothing changed
  if (v) retired.push_back(std::move(v));
  v = std::move(built);
  bytes += v->memory_bytes();
  return *v;
}

GatherCache::GatherCache() : impl_(std::make_unique<Impl>()) {}
GatherCache::~GatherCache() = default;

size_t GatherCache::memory_bytes() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->bytes;
}

}  // namespace pbgi
