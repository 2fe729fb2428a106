#include "storage/format/page_records.h"

#include "storage/format/byte_order.h"
#include "storage/format/page_frame.h"

namespace pbgi::storage {

static_assert(min_page_bytes(0) ==
              kPageHeaderBytes + kPageTrailerBytes + kTopologyRecordBytes + kMaxPayloadBytesPerNode);

namespace {
inline uint8_t* put3(uint8_t* p, float x, float y, float z) {
  store_le<float>(p, x);
  store_le<float>(p + 4, y);
  store_le<float>(p + 8, z);
  return p + 12;
}
template <typename V>
inline const uint8_t* get3(const uint8_t* p, V& v) {
  v.x = load_le<float>(p);
  v.y = load_le<float>(p + 4);
  v.z = load_le<float>(p + 8);
  return p + 12;
}
}  // namespace

void write_topology_record(const tree::Node& n, uint8_t* out) {
  uint8_t* p = put3(out, n.center.x, n.center.y, n.center.z);   // 0
  store_le<float>(p, n.radius);                                 // 12
  p = put3(p + 4, n.cone_axis.x, n.cone_axis.y, n.cone_axis.z); // 16
  store_le<float>(p, n.cone_cos);                               // 28
  store_le<float>(p + 4, n.area);                               // 32
  store_le<uint32_t>(p + 8, n.child_count);                     // 36
  store_le<uint32_t>(p + 12, n.first_surfel);                   // 40
  store_le<uint32_t>(p + 16, n.surfel_count);                   // 44
  for (int c = 0; c < tree::Node::kMaxChildren; ++c) {          // 48, 56
    store_le<uint32_t>(p + 20 + 8 * c, n.children[c].page);
    store_le<uint32_t>(p + 24 + 8 * c, n.children[c].index);
  }
}

void read_topology_record(const uint8_t* in, tree::Node& n) {
  const uint8_t* p = get3(in, n.center);
  n.radius = load_le<float>(p);
  p = get3(p + 4, n.cone_axis);
  n.cone_cos = load_le<float>(p);
  n.area = load_le<float>(p + 4);
  n.child_count = load_le<uint32_t>(p + 8);
  n.first_surfel = load_le<uint32_t>(p + 12);
  n.surfel_count = load_le<uint32_t>(p + 16);
  for (int c = 0; c < tree::Node::kMaxChildren; ++c) {
    n.children[c].page = load_le<uint32_t>(p + 20 + 8 * c);
    n.children[c].index = load_le<uint32_t>(p + 24 + 8 * c);
  }
}

void write_surfel_record(const Surfel& s, uint8_t* out) {
  uint8_t* p = put3(out, s.position.x, s.position.y, s.position.z);  // 0
  p = put3(p, s.normal.x, s.normal.y, s.normal.z);                    // 12
  store_le<float>(p, s.radius);                                       // 24
  p = put3(p + 4, s.albedo.x, s.albedo.y, s.albedo.z);                // 28
  p = put3(p, s.emission.x, s.emission.y, s.emission.z);              // 40
  put3(p, s.radiance.x, s.radiance.y, s.radiance.z);                  // 52
}

void read_surfel_record(const uint8_t* in, Surfel& s) {
  const uint8_t* p = get3(in, s.position);
  p = get3(p, s.normal);
  s.radius = load_le<float>(p);
  p = get3(p + 4, s.albedo);
  p = get3(p, s.emission);
  get3(p, s.radiance);
}

}  // namespace pbgi::storage
