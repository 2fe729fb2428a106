#include "storage/format/page_records.h"

#include "storage/format/byte_order.h"
#include "storage/format/packed_values.h"
#include "storage/format/page_frame.h"

namespace pbgi::storage {

static_assert(kPageOverheadBytes == kPageHeaderBytes + kPageTrailerBytes + 3);

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

uint8_t encode_shape(const NodeShape& s) {
  return uint8_t(s.child_count & 3u) | uint8_t(s.external[0] ? 4u : 0u) |
         uint8_t(s.external[1] ? 8u : 0u);
}

bool decode_shape(uint8_t byte, NodeShape& out) {
  out.child_count = byte & 3u;
  out.external[0] = (byte & 4u) != 0;
  out.external[1] = (byte & 8u) != 0;
  if (byte & 0xf0u) return false;
  if (out.child_count > 2) return false;
  if (out.external[0] && out.child_count < 1) return false;
  if (out.external[1] && out.child_count < 2) return false;
  return true;
}

void write_leaf_record(const LeafFrame& f, uint32_t surfel_count, uint8_t* out) {
  uint8_t* p = put3(out, f.center.x, f.center.y, f.center.z);  // 0
  store_le<float>(p, f.radius);                                 // 12
  store_le<uint16_t>(p + 4, uint16_t(surfel_count));            // 16
}

void read_leaf_record(const uint8_t* in, LeafFrame& f, uint32_t& surfel_count) {
  const uint8_t* p = get3(in, f.center);
  f.radius = load_le<float>(p);
  surfel_count = load_le<uint16_t>(p + 4);
}

void write_link_record(uint32_t page, const tree::Node& n, uint8_t* out) {
  store_le<uint32_t>(out, page);                                       // 0
  uint8_t* p = put3(out + 4, n.center.x, n.center.y, n.center.z);      // 4
  store_le<float>(p, n.radius);                                        // 16
  p = put3(p + 4, n.cone_axis.x, n.cone_axis.y, n.cone_axis.z);        // 20
  store_le<float>(p, n.cone_cos);                                      // 32
  store_le<float>(p + 4, n.area);                                      // 36
}

void read_link_record(const uint8_t* in, uint32_t& page, tree::Node& n) {
  page = load_le<uint32_t>(in);
  const uint8_t* p = get3(in + 4, n.center);
  n.radius = load_le<float>(p);
  p = get3(p + 4, n.cone_axis);
  n.cone_cos = load_le<float>(p);
  n.area = load_le<float>(p + 4);
}

void encode_surfel_record(const Surfel& s, const LeafFrame& f, uint8_t* out) {
  // A zero-radius frame (every surfel a point at the center) stores zeros.
  const float inv = f.radius > 0.f ? 1.f / f.radius : 0.f;
  const Imath::V3f d = (s.position - f.center) * inv;
  store_le<uint16_t>(out + 0, uint16_t(encode_snorm16(d.x)));
  store_le<uint16_t>(out + 2, uint16_t(encode_snorm16(d.y)));
  store_le<uint16_t>(out + 4, uint16_t(encode_snorm16(d.z)));
  store_le<uint32_t>(out + 6, encode_octahedral(s.normal));
  store_le<uint16_t>(out + 10, encode_unorm16(s.radius * inv));
  store_le<uint32_t>(out + 12, encode_rgb9e5(s.albedo));
  store_le<uint32_t>(out + 16, encode_rgb9e5(s.emission));
  store_le<uint32_t>(out + 20, encode_rgb9e5(s.radiance));
}

void decode_surfel_record(const uint8_t* in, const LeafFrame& f, Surfel& s) {
  const float R = f.radius;
  s.position.x = f.center.x + R * decode_snorm16(int16_t(load_le<uint16_t>(in + 0)));
  s.position.y = f.center.y + R * decode_snorm16(int16_t(load_le<uint16_t>(in + 2)));
  s.position.z = f.center.z + R * decode_snorm16(int16_t(load_le<uint16_t>(in + 4)));
  s.normal = decode_octahedral(load_le<uint32_t>(in + 6));
  s.radius = R * decode_unorm16(load_le<uint16_t>(in + 10));
  s.albedo = decode_rgb9e5(load_le<uint32_t>(in + 12));
  s.emission = decode_rgb9e5(load_le<uint32_t>(in + 16));
  s.radiance = decode_rgb9e5(load_le<uint32_t>(in + 20));
}

}  // namespace pbgi::storage
