#include "storage/tree/tree_builder.h"

#include "storage/format/errors.h"
#include "storage/tree/bounding_sphere.h"
#include "storage/tree/node_payload.h"
#include "storage/tree/normal_cone.h"

#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <span>
#include <string>
#include <utility>

namespace pbgi::tree {

namespace {

// Node counts of the trees over m and m + 1 surfels. The two halves of m and
// m + 1 surfels are always among {m/2, m/2 + 1}, so one recursion on m/2
// gives both: O(log m).
std::pair<uint64_t, uint64_t> node_count_pair(uint64_t m, uint32_t leaf) {
  if (m + 1 <= leaf) return {1, 1};
  const uint64_t k = m / 2;
  const auto [ck, ck1] = node_count_pair(k, leaf);
  auto count = [&](uint64_t x) -> uint64_t {
    if (x <= leaf) return 1;
    const uint64_t lo = x / 2, hi = x - x / 2;
    return 1 + (lo == k ? ck : ck1) + (hi == k ? ck : ck1);
  };
  return {count(m), count(m + 1)};
}

// Below this many surfels a subtree is built on the calling thread: the
// task overhead would outweigh the work.
constexpr size_t kParallelGrain = 16384;

// What the partition moves around: 16 bytes instead of a 64-byte surfel,
// so the O(n log n) part of the build streams a quarter of the memory.
struct Item {
  Imath::V3f position;
  uint32_t surfel;  // index into the input surfels
};

struct Builder {
  std::vector<Node>& nodes;
  std::vector<Item>& items;
  const std::vector<Surfel>& in;  // input order
  std::vector<Surfel>& out;       // leaf order
  uint32_t leaf_size;
  std::atomic<uint64_t> leaf_count{0};
  std::atomic<uint32_t> max_depth{0};

  void build(uint64_t node, size_t begin, size_t end, uint32_t depth) {
    const size_t n = end - begin;
    Node& out_node = nodes[node];
    if (n <= leaf_size) {
      // The items of a leaf are final: place its surfels in leaf order.
      for (size_t i = begin; i < end; ++i) out[i] = in[items[i].surfel];
      make_leaf(out_node, begin, n);
      leaf_count.fetch_add(1, std::memory_order_relaxed);
      uint32_t d = max_depth.load(std::memory_order_relaxed);
      while (depth > d && !max_depth.compare_exchange_weak(d, depth, std::memory_order_relaxed)) {}
      return;
    }
    // 1. Split at the median along the largest axis of the centroid bounds.
    Imath::V3f lo(std::numeric_limits<float>::infinity()), hi(-std::numeric_limits<float>::infinity());
    for (size_t i = begin; i < end; ++i) {
      const Imath::V3f& p = items[i].position;
      lo.x = std::min(lo.x, p.x);
      lo.y = std::min(lo.y, p.y);
      lo.z = std::min(lo.z, p.z);
      hi.x = std::max(hi.x, p.x);
      hi.y = std::max(hi.y, p.y);
      hi.z = std::max(hi.z, p.z);
    }
    const Imath::V3f extent = hi - lo;
    const int axis = extent.x >= extent.y ? (extent.x >= extent.z ? 0 : 2) : (extent.y >= extent.z ? 1 : 2);
    const size_t mid = begin + n / 2;
    std::nth_element(items.begin() + begin, items.begin() + mid, items.begin() + end,
                     [axis](const Item& a, const Item& b) { return a.position[axis] < b.position[axis]; });

    // 2. Children: the left one follows in pre-order, the right one after
    //    the whole left subtree.
    const uint64_t left = node + 1;
    const uint64_t right = left + tree_node_count(n / 2, leaf_size);
    if (n >= kParallelGrain) {
      tbb::parallel_invoke([&] { build(left, begin, mid, depth + 1); },
                           [&] { build(right, mid, end, depth + 1); });
    } else {
      build(left, begin, mid, depth + 1);
      build(right, mid, end, depth + 1);
    }

    // 3. Bounds and payload from the children.
    const Node& a = nodes[left];
    const Node& b = nodes[right];
    const Sphere s = merge_spheres({a.center, a.radius}, {b.center, b.radius});
    const NormalCone c = merge_cones({a.cone_axis, a.cone_cos}, {b.cone_axis, b.cone_cos});
    out_node.center = s.center;
    out_node.radius = s.radius;
    out_node.cone_axis = c.axis;
    out_node.cone_cos = c.cos_half_angle;
    out_node.child_count = 2;
    out_node.children[0] = {0, static_cast<uint32_t>(left)};
    out_node.children[1] = {0, static_cast<uint32_t>(right)};
    PayloadAccumulator acc;
    acc.add_node(a);
    acc.add_node(b);
    acc.store(out_node);
  }

  void make_leaf(Node& node, size_t begin, size_t n) {
    const std::span<const Surfel> s(out.data() + begin, n);
    const Sphere sphere = sphere_of_disks(s);
    const NormalCone cone = cone_of_normals(s);
    node.center = sphere.center;
    node.radius = sphere.radius;
    node.cone_axis = cone.axis;
    node.cone_cos = cone.cos_half_angle;
    node.child_count = 0;
    node.first_surfel = static_cast<uint32_t>(begin);
    node.surfel_count = static_cast<uint32_t>(n);
    PayloadAccumulator acc;
    for (const Surfel& x : s) acc.add_surfel(x);
    acc.store(node);
  }
};

bool finite(const Imath::V3f& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

// Checks every surfel and renormalizes its normal; names the first bad one.
void check_surfels(std::vector<Surfel>& surfels) {
  std::atomic<size_t> first_bad{std::numeric_limits<size_t>::max()};
  tbb::parallel_for(tbb::blocked_range<size_t>(0, surfels.size(), 4096), [&](const auto& r) {
    for (size_t i = r.begin(); i < r.end(); ++i) {
      Surfel& s = surfels[i];
      const float len = s.normal.length();
      const bool ok = finite(s.position) && finite(s.normal) && std::isfinite(s.radius) &&
                      s.radius >= 0 && len > 1e-6f && finite(s.radiance) && finite(s.albedo) &&
                      finite(s.emission);
      if (!ok) {
        size_t cur = first_bad.load();
        while (i < cur && !first_bad.compare_exchange_weak(cur, i)) {}
        continue;
      }
      s.normal /= len;
    }
  });
  const size_t bad = first_bad.load();
  if (bad != std::numeric_limits<size_t>::max()) {
    const Surfel& s = surfels[bad];
    throw InvalidArgument("surfel " + std::to_string(bad) +
                          " is invalid (non-finite field, negative radius or zero normal): position (" +
                          std::to_string(s.position.x) + ", " + std::to_string(s.position.y) + ", " +
                          std::to_string(s.position.z) + "), radius " + std::to_string(s.radius));
  }
}

}  // namespace

uint64_t tree_node_count(uint64_t surfel_count, uint32_t leaf_size) {
  if (surfel_count == 0) return 0;
  return node_count_pair(surfel_count, std::max<uint32_t>(leaf_size, 1)).first;
}

BuiltTree build_tree(std::vector<Surfel> surfels, const BuildOptions& options) {
  options.validate();
  if (surfels.empty()) throw InvalidArgument("cannot build a tree over 0 surfels");
  constexpr size_t kMaxSurfels = size_t(1) << 31;
  if (surfels.size() > kMaxSurfels) {
    throw InvalidArgument("cannot build a tree over " + std::to_string(surfels.size()) +
                          " surfels (at most " + std::to_string(kMaxSurfels) + ")");
  }
  const uint64_t node_count = tree_node_count(surfels.size(), options.leaf_size);
  if (node_count > std::numeric_limits<uint32_t>::max()) {
    throw InvalidArgument("tree over " + std::to_string(surfels.size()) + " surfels with leaf_size " +
                          std::to_string(options.leaf_size) + " would have more than 2^32 nodes");
  }
  check_surfels(surfels);

  BuiltTree t;
  t.nodes.resize(node_count);
  t.surfels.resize(surfels.size());
  std::vector<Item> items(surfels.size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, surfels.size(), 8192), [&](const auto& r) {
    for (size_t i = r.begin(); i < r.end(); ++i) items[i] = {surfels[i].position, uint32_t(i)};
  });
  Builder b{t.nodes, items, surfels, t.surfels, options.leaf_size};
  b.build(0, 0, surfels.size(), 0);
  t.leaf_count = b.leaf_count.load();
  t.max_depth = b.max_depth.load();
  return t;
}

}  // namespace pbgi::tree
