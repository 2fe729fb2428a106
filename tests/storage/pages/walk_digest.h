// A digest of everything a reader derives from a page set: every node's
// summary (bounds, cone, area, payload, counts, depth) and every leaf
// surfel, in a depth-first walk from the root (child 0 first), as
// XXH3-64 over their bytes. Two readers that agree on the digest decode
// the set identically, bit for bit. Used to pin what an older build's
// reader derived from a page set of an older format (v6_page_set_test).
#pragma once

#include "storage/format/checksum.h"
#include "storage/tree/node.h"

#include <cstdint>
#include <cstring>
#include <vector>

namespace pbgi::test {

inline uint64_t walk_digest(const tree::TreeSource& src) {
  std::vector<uint8_t> bytes;
  auto put = [&](const void* p, size_t n) {
    const auto* b = static_cast<const uint8_t*>(p);
    bytes.insert(bytes.end(), b, b + n);
  };
  auto put3 = [&](const Imath::V3f& v) { put(&v.x, 4), put(&v.y, 4), put(&v.z, 4); };
  struct Item {
    tree::NodeRef ref;
    uint32_t depth;
  };
  std::vector<Item> stack{{src.root(), 0}};
  while (!stack.empty()) {
    const Item it = stack.back();
    stack.pop_back();
    const tree::PagePtr page = src.page(it.ref.page);
    const tree::Node& n = page->nodes.at(it.ref.index);
    put3(n.center);
    put(&n.radius, 4);
    put3(n.cone_axis);
    put(&n.cone_cos, 4);
    put(&n.area, 4);
    put(n.radiance_sh.r.data(), 36), put(n.radiance_sh.g.data(), 36), put(n.radiance_sh.b.data(), 36);
    put(n.coverage_sh.data(), 36);
    put(&n.child_count, sizeof n.child_count);
    put(&n.surfel_count, 4);
    put(&it.depth, 4);
    if (n.is_leaf()) {
      for (uint32_t k = 0; k < n.surfel_count; ++k) {
        const Surfel& s = page->surfels.at(n.first_surfel + k);
        put3(s.position), put3(s.normal);
        put(&s.radius, 4);
        put3(Imath::V3f(s.albedo.x, s.albedo.y, s.albedo.z));
        put3(Imath::V3f(s.emission.x, s.emission.y, s.emission.z));
        put3(Imath::V3f(s.radiance.x, s.radiance.y, s.radiance.z));
      }
    }
    for (uint32_t c = n.child_count; c-- > 0;) stack.push_back({n.children[c], it.depth + 1});
  }
  return storage::checksum64(bytes.data(), bytes.size());
}

}  // namespace pbgi::test
