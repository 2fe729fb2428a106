#include "server/gather/page_views.h"

#include "common/errors.h"

#include <algorithm>
#include <memory>
#include <new>
#include <type_traits>
#include <cmath>
#include <cstdlib>
#include <string>

namespace pbgi::gather {

namespace {

bool finite(const Imath::V3f& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

std::string where(const tree::Page& page, size_t node) {
  return "tree page " + std::to_string(page.id) + " node " + std::to_string(node);
}

}  // namespace

namespace {

// What build() derives from a page before it lays the view out in one
// allocation.
struct ViewParts {
  std::vector<HotNode> nodes;
  std::vector<NodeLook> looks;
  std::vector<WideNode> full;
  std::vector<Bipolar> bipolar;
  std::vector<uint32_t> bipolar_index;
  float node0_dc[4] = {0.f, 0.f, 0.f, 0.f};

  // Fills nodes[i] and looks[i] (and the bipolar or full entry) from `n`;
  // returns the HotNode flags.
  uint32_t describe(const tree::Node& n, size_t i, const storage::GlossyNodes* glossy, size_t page_nodes);
};

uint32_t ViewParts::describe(const tree::Node& n, size_t i, const storage::GlossyNodes* glossy,
                             size_t page_nodes) {
  HotNode& h = nodes[i];
  h.cx = n.center.x;
  h.cy = n.center.y;
  h.cz = n.center.z;
  h.radius = n.radius;
  h.ax = n.cone_axis.x;
  h.ay = n.cone_axis.y;
  h.az = n.cone_axis.z;
  const bool cone = n.cone_cos > -1.f;  // also false for NaN
  h.cone_cos = cone ? std::min(n.cone_cos, 1.f) : -2.f;
  h.cone_sin = cone ? std::sqrt(std::max(0.f, 1.f - h.cone_cos * h.cone_cos)) : 1.f;
  // angle(axis, n) + beta < kCoplanarAngle  <=>  dot(axis, n) > cos(kCoplanarAngle - beta)
  //   = cos(kCoplanarAngle) cos(beta) + sin(kCoplanarAngle) sin(beta).
  const float cos_c = std::cos(kCoplanarAngle), sin_c = std::sin(kCoplanarAngle);
  h.coplanar_cos = cone && h.cone_cos > cos_c ? cos_c * h.cone_cos + sin_c * h.cone_sin : 2.f;

  uint32_t flags = 0;
  NodeLook& look = looks[i];
  look = NodeLook{};  // zeros; no full entry
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
      if (bipolar_index.empty()) bipolar_index.assign(nodes.size(), 0);
      bipolar_index[i] = uint32_t(bipolar.size());
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
    look.full = uint32_t(full.size());
    full.push_back(wide_node(n));
  }
  // Nothing to see: no area, or NaN/negative/infinite bounds.
  if (!(n.area > 0.f) || !(n.radius >= 0.f) || !std::isfinite(n.radius) || !finite(n.center)) {
    flags |= HotNode::kInvisible;
  }
  return flags;
}

ViewParts derive_parts(const tree::Page& page) {
  ViewParts parts;
  const size_t n = page.nodes.size();
  parts.nodes.resize(n + page.links.size());
  parts.looks.resize(n + page.links.size());
  const storage::GlossyNodes* glossy = page.glossy.get();
  for (size_t i = 0; i < n; ++i) {
    const tree::Node& node = page.nodes[i];
    HotNode& h = parts.nodes[i];
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
      h.first = 0;
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
    HotNode& h = parts.nodes[i];
    h.count = parts.describe(l.summary, i, glossy, n) | HotNode::kProxy | 1u;
    h.first = 0;
    h.children[0] = l.summary.children[0];
    parts.nodes[l.parent].children[l.slot] = {page.id, uint32_t(i)};
  }
  return parts;
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

PageView::Ptr PageView::build(const tree::Page& page) {
  const ViewParts parts = derive_parts(page);
  static_assert(std::is_trivially_destructible_v<HotNode> && std::is_trivially_destructible_v<NodeLook> &&
                    std::is_trivially_destructible_v<WideNode> && std::is_trivially_destructible_v<Bipolar> &&
                    std::is_trivially_destructible_v<LeafSurfel>,
                "parts are copy-constructed into raw storage and never destroyed");
  // Header, nodes (64-byte lines), looks (half lines), leaf surfels, full
  // nodes, bipolar faces and index, then the cold part.
  const size_t nodes_at = sizeof(PageView);
  const size_t looks_at = nodes_at + parts.nodes.size() * sizeof(HotNode);
  const size_t surfels_at = looks_at + parts.looks.size() * sizeof(NodeLook);
  static_assert(alignof(LeafSurfel) <= alignof(NodeLook), "surfels() follows the looks unpadded");
  const size_t full_at = round_up(surfels_at + page.surfels.size() * sizeof(LeafSurfel), alignof(WideNode));
  const size_t bipolar_at = round_up(full_at + parts.full.size() * sizeof(WideNode), alignof(Bipolar));
  const size_t index_at = round_up(bipolar_at + parts.bipolar.size() * sizeof(Bipolar), alignof(uint32_t));
  const size_t cold_at = round_up(index_at + parts.bipolar_index.size() * sizeof(uint32_t), alignof(Cold));
  // posix_memalign, not aligned operator new: libstdc++'s rounds the size
  // up to the alignment (C11 aligned_alloc's rule), 64 bytes a view on
  // average; glibc's posix_memalign returns what precedes the aligned
  // start to the heap and takes only the block the size needs. (jemalloc,
  // which pbgid links, rounds an aligned block to a size class that is a
  // multiple of the alignment either way: the charge is then up to 112
  // bytes short.)
  const size_t bytes = round_up(cold_at + sizeof(Cold), 16);

  void* memory = nullptr;
  if (posix_memalign(&memory, kViewAlign, bytes) != 0) throw std::bad_alloc();
  auto* base = static_cast<std::byte*>(memory);
  auto* view = new (base) PageView();
  Ptr owned(view);
  view->id = page.id;
  view->page_nodes = uint32_t(page.nodes.size());
  view->node_count = uint32_t(parts.nodes.size());
  view->bipolar_count = uint32_t(parts.bipolar.size());
  copy_to(base, nodes_at, parts.nodes);
  view->looks = copy_to(base, looks_at, parts.looks);
  auto* surfels = reinterpret_cast<LeafSurfel*>(base + surfels_at);
  for (const Surfel& s : page.surfels) *surfels++ = {s.position, s.radius, s.normal, s.radiance};
  view->full_nodes = copy_to(base, full_at, parts.full);
  view->bipolar = copy_to(base, bipolar_at, parts.bipolar);
  view->bipolar_index = parts.bipolar_index.empty() ? nullptr : copy_to(base, index_at, parts.bipolar_index);
  view->glossy = page.glossy.get();
  Cold* cold = new (base + cold_at) Cold();
  cold->glossy = page.glossy;
  cold->surfel_count = page.surfels.size();
  cold->bytes = tree::heap_block_bytes(bytes);
  cold->full_count = uint32_t(parts.full.size());
  std::copy(parts.node0_dc, parts.node0_dc + 4, cold->node0_dc);
  view->cold = cold;
  return owned;
}

void PageView::Free::operator()(PageView* v) const {
  if (!v) return;
  if (v->cold) v->cold->~Cold();
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

namespace {
struct AttachedView final : tree::PageAttachment {
  explicit AttachedView(const tree::Page& page) : view(PageView::build(page)) {}
  // Its make_shared block, then the view's.
  size_t memory_bytes() const override {
    return tree::heap_block_bytes(tree::Page::kSharedControlBytes + sizeof(AttachedView)) + view->memory_bytes();
  }
  PageView::Ptr view;
};
}  // namespace

void attach_view(tree::Page& page) {
  page.attachment = std::make_shared<AttachedView>(page);
  // Freed, not only emptied: `page.nodes = {}` assigns an empty list and
  // keeps the capacity (and the cache's charge) of every decoded node.
  std::vector<tree::Node>().swap(page.nodes);
  std::vector<tree::PageLink>().swap(page.links);
  std::vector<Surfel>().swap(page.surfels);
}

const PageView& PageViews::get(const tree::Page& page) {
  // An attached view lives exactly as long as its page, which the caller
  // pins: it is never remembered in a slot, which would dangle once the
  // cache evicts the page.
  if (const auto* attached = dynamic_cast<const AttachedView*>(page.attachment.get())) {
    return *attached->view;
  }
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
