#include "server/gather/page_views.h"

#include "common/errors.h"

#include <algorithm>
#include <cmath>
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

PageView::PageView(const tree::Page& page)
    : id(page.id), page_nodes(uint32_t(page.nodes.size())), glossy(page.glossy), surfel_count(page.surfels.size()) {
  const size_t n = page.nodes.size();
  nodes.resize(n + page.links.size());
  looks.resize(n + page.links.size());
  for (size_t i = 0; i < n; ++i) {
    const tree::Node& node = page.nodes[i];
    HotNode& h = nodes[i];
    const uint32_t flags = describe(node, i);
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
    HotNode& h = nodes[i];
    h.count = describe(l.summary, i) | HotNode::kProxy | 1u;
    h.first = 0;
    h.children[0] = l.summary.children[0];
    nodes[l.parent].children[l.slot] = {page.id, uint32_t(i)};
  }
  full_nodes = full.data();
}

uint32_t PageView::describe(const tree::Node& n, size_t i) {
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
        look.fan = fan_cone(n.cone_cos);
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
    full.push_back(n);
  }
  // Nothing to see: no area, or NaN/negative/infinite bounds.
  if (!(n.area > 0.f) || !(n.radius >= 0.f) || !std::isfinite(n.radius) || !finite(n.center)) {
    flags |= HotNode::kInvisible;
  }
  return flags;
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
  explicit AttachedView(const tree::Page& page) : view(page) {}
  size_t memory_bytes() const override { return sizeof(AttachedView) - sizeof(PageView) + view.memory_bytes(); }
  PageView view;
};
}  // namespace

void attach_view(tree::Page& page) {
  page.attachment = std::make_shared<AttachedView>(page);
  page.nodes = {};
  page.links = {};
}

const PageView& PageViews::get(const tree::Page& page) {
  // An attached view lives exactly as long as its page, which the caller
  // pins: it is never remembered in a slot, which would dangle once the
  // cache evicts the page.
  if (const auto* attached = dynamic_cast<const AttachedView*>(page.attachment.get())) {
    return attached->view;
  }
  const PageView*& s = slot(page.id);
  if (s && s->matches(page)) return *s;
  if (shared_) {
    s = &shared_->get(page);
    return *s;
  }
  // A stale view of this id stays owned until the next clear(): the
  // caller's stack may still point to it.
  owned_.push_back(std::make_unique<PageView>(page));
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
  std::unique_ptr<gather::PageView>& v = views[page.id];
  if (v && v->matches(page)) return *v;
  auto built = std::make_unique<gather::PageView>(page);  // may throw: nothing changed
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
