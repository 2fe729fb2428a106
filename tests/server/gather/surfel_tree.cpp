#include "surfel_tree.h"

#include "common/errors.h"
#include "storage/sh/sh.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace pbgi::test {

namespace {

struct BuildNode {
  tree::Node node;
  int32_t child[2] = {-1, -1};
  uint32_t first = 0, count = 0;  // leaf surfel range in the builder's order
};

class Builder {
 public:
  Builder(std::vector<Surfel>& s, uint32_t leaf_size) : s_(s), leaf_size_(leaf_size) {}

  int32_t build(uint32_t begin, uint32_t end) {
    const int32_t id = int32_t(nodes_.size());
    nodes_.emplace_back();
    describe(nodes_[id].node, begin, end);
    if (end - begin <= leaf_size_) {
      nodes_[id].first = begin;
      nodes_[id].count = end - begin;
      return id;
    }
    Imath::V3f lo(1e30f), hi(-1e30f);
    for (uint32_t i = begin; i < end; ++i) {
      for (int a = 0; a < 3; ++a) {
        lo[a] = std::min(lo[a], s_[i].position[a]);
        hi[a] = std::max(hi[a], s_[i].position[a]);
      }
    }
    const Imath::V3f ext = hi - lo;
    const int axis = ext.x >= ext.y && ext.x >= ext.z ? 0 : (ext.y >= ext.z ? 1 : 2);
    const uint32_t mid = begin + (end - begin) / 2;
    std::nth_element(
        s_.begin() + begin, s_.begin() + mid, s_.begin() + end,
        [axis](const Surfel& a, const Surfel& b) { return a.position[axis] < b.position[axis]; });
    const int32_t left = build(begin, mid);
    const int32_t right = build(mid, end);
    nodes_[id].child[0] = left;
    nodes_[id].child[1] = right;
    return id;
  }

  std::vector<BuildNode>& nodes() { return nodes_; }

 private:
  // Bounds, cone and payload straight from the surfels (not from children):
  // simple and exactly what node.h specifies.
  void describe(tree::Node& n, uint32_t begin, uint32_t end) const {
    // Centroid in double: a scene far from the origin (1e5) gets the
    // nearest float to its true centroid, as near the origin.
    Imath::V3d csum(0);
    Imath::V3f normal_sum(0);
    double area = 0;
    for (uint32_t i = begin; i < end; ++i) {
      csum += Imath::V3d(s_[i].position);
      normal_sum += s_[i].normal;
      area += s_[i].area();
    }
    const uint32_t count = end - begin;
    Imath::V3f c(0);
    if (count > 0) c = Imath::V3f(csum / double(count));
    float radius = 0.f;
    for (uint32_t i = begin; i < end; ++i) {
      radius = std::max(radius, (s_[i].position - c).length() + s_[i].radius);
    }
    n.center = c;
    n.radius = radius;
    n.area = float(area);
    n.cone_axis = Imath::V3f(0, 0, 1);
    n.cone_cos = -1.f;
    if (count > 0 && normal_sum.length() > 1e-3f * float(count)) {
      n.cone_axis = normal_sum.normalized();
      float min_cos = 1.f;
      for (uint32_t i = begin; i < end; ++i)
        min_cos = std::min(min_cos, n.cone_axis.dot(s_[i].normal));
      n.cone_cos = std::max(-1.f, std::cos(std::acos(std::clamp(min_cos, -1.f, 1.f)) + 1e-5f));
    }
    if (area > 0) {
      for (uint32_t i = begin; i < end; ++i) {
        const float w = float(s_[i].area() / area);
        const sh::Sh9 lobe = sh::clamped_cosine(s_[i].normal);
        sh::add_scaled(n.radiance_sh, lobe, s_[i].radiance * w);
        sh::add_scaled(n.coverage_sh, lobe, w);
      }
    }
  }

  std::vector<Surfel>& s_;
  uint32_t leaf_size_;
  std::vector<BuildNode> nodes_;
};

}  // namespace

SurfelTree::SurfelTree(std::vector<Surfel> surfels, SurfelTreeOptions options) {
  for (Surfel& s : surfels) {
    const float len = s.normal.length();
    if (len > 0.f) s.normal /= len;
  }
  Builder builder(surfels, std::max(1u, options.leaf_size));
  builder.build(0, uint32_t(surfels.size()));
  std::vector<BuildNode>& nodes = builder.nodes();
  node_count_ = nodes.size();

  const uint32_t per_page = std::max(1u, options.nodes_per_page);
  const uint32_t page_count = uint32_t((nodes.size() + per_page - 1) / per_page);
  refs_ = std::make_unique<std::atomic<uint32_t>[]>(page_count);
  for (uint32_t p = 0; p < page_count; ++p) {
    refs_[p] = 0;
    auto page = std::make_shared<tree::Page>();
    page->id = p;
    pages_.push_back(page);
  }
  for (size_t i = 0; i < nodes.size(); ++i) {
    BuildNode& b = nodes[i];
    tree::Page& page = *pages_[i / per_page];
    tree::Node n = b.node;
    if (b.child[0] >= 0) {
      n.child_count = 2;
      for (int c = 0; c < 2; ++c) {
        n.children[c] = {uint32_t(b.child[c] / per_page), uint32_t(b.child[c] % per_page)};
      }
    } else {
      n.child_count = 0;
      n.first_surfel = uint32_t(page.surfels.size());
      n.surfel_count = b.count;
      for (uint32_t k = 0; k < b.count; ++k) page.surfels.push_back(surfels[b.first + k]);
    }
    page.nodes.push_back(n);
  }
}

tree::PagePtr SurfelTree::page(uint32_t id) const {
  if (id >= pages_.size()) throw InvalidArgument("SurfelTree: no page " + std::to_string(id));
  ++fetches_;
  if (refs_[id].fetch_add(1) == 0) {
    const size_t in_use = in_use_.fetch_add(1) + 1;
    size_t seen = max_in_use_.load();
    while (in_use > seen && !max_in_use_.compare_exchange_weak(seen, in_use)) {
    }
  }
  std::atomic<uint32_t>* refs = &refs_[id];
  std::atomic<size_t>* in_use = &in_use_;
  std::shared_ptr<tree::Page> page = pages_[id];
  tree::Page* raw = page.get();
  return tree::PagePtr(raw, [refs, in_use, page = std::move(page)](tree::Page*) mutable {
    if (refs->fetch_sub(1) == 1) in_use->fetch_sub(1);
    page.reset();
  });
}

size_t SurfelTree::pages_in_use() const { return in_use_.load(); }

}  // namespace pbgi::test
