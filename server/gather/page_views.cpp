#include "server/gather/page_views.h"

#include "storage/format/errors.h"

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

PageView::PageView(const tree::Page& page) : id(page.id), surfel_count(page.surfels.size()) {
  nodes.resize(page.nodes.size());
  for (size_t i = 0; i < page.nodes.size(); ++i) {
    const tree::Node& n = page.nodes[i];
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
    const float beta = cone ? std::acos(h.cone_cos) : 4.f;
    h.coplanar_cos = beta < kCoplanarAngle ? std::cos(kCoplanarAngle - beta) : 2.f;

    uint32_t flags = 0;
    // Nothing to see: no area, or NaN/negative/infinite bounds.
    if (!(n.area > 0.f) || !(n.radius >= 0.f) || !std::isfinite(n.radius) || !finite(n.center)) {
      flags |= HotNode::kInvisible;
    }
    if (n.is_leaf()) {
      const uint64_t end = uint64_t(n.first_surfel) + n.surfel_count;
      if (end > page.surfels.size()) {
        throw CorruptionError("tree page " + std::to_string(page.id) + " leaf " +
                              std::to_string(i) + ": surfels [" + std::to_string(n.first_surfel) +
                              ", " + std::to_string(end) + ") outside the page's " +
                              std::to_string(page.surfels.size()));
      }
      if (n.surfel_count > HotNode::kCountMask) {
        throw CorruptionError(where(page, i) + ": " + std::to_string(n.surfel_count) +
                              " surfels in one leaf");
      }
      h.first = n.first_surfel;
      h.count = flags | HotNode::kLeaf | n.surfel_count;
    } else {
      if (n.child_count > tree::Node::kMaxChildren) {
        throw CorruptionError(where(page, i) + ": child_count " + std::to_string(n.child_count) +
                              " exceeds " + std::to_string(tree::Node::kMaxChildren));
      }
      h.first = uint32_t(links.size());
      h.count = flags | n.child_count;
      for (uint32_t c = 0; c < n.child_count; ++c) {
        const tree::NodeRef ref = n.children[c];
        if (ref.page == page.id && ref.index >= page.nodes.size()) {
          throw CorruptionError(where(page, i) + ": child link to page " +
                                std::to_string(ref.page) + " node " + std::to_string(ref.index) +
                                " is out of range (" + std::to_string(page.nodes.size()) +
                                " nodes)");
        }
        links.push_back(ref);
      }
    }
  }
}

const PageView& PageViews::get(const tree::Page& page) {
  std::unique_ptr<PageView>* slot;
  if (page.id < kDenseIds) {
    if (page.id >= dense_.size()) dense_.resize(std::max<size_t>(page.id + 1, 2 * dense_.size()));
    slot = &dense_[page.id];
  } else {
    slot = &sparse_[page.id];
  }
  if (*slot && (*slot)->matches(page)) return **slot;
  if (*slot) bytes_ -= (*slot)->memory_bytes();
  *slot = std::make_unique<PageView>(page);
  bytes_ += (*slot)->memory_bytes();
  ++built_;
  return **slot;
}

void PageViews::clear() {
  dense_.clear();
  sparse_.clear();
  bytes_ = 0;
}

}  // namespace pbgi::gather
