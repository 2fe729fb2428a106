#include "storage/tree/page_records.h"

#include "common/errors.h"
#include "storage/format/byte_order.h"
#include "storage/format/packed_values.h"
#include "storage/format/page_frame.h"
#include "storage/tree/bounds_rounding.h"

#include <Imath/half.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstddef>

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

namespace {
// 2^e as a float from its bits (e in [-126, 127]): exact, unlike ldexp's
// callers' arithmetic, and cheap.
float pow2f(int e) { return std::bit_cast<float>(uint32_t(e + 127) << 23); }
constexpr int kFrameExponentBias = 128;
constexpr int kFrameCenterBits = 21;  // |k| <= 2^22
int ilogb_or_min(float v) { return v > 0.f ? std::ilogb(v) : kMinFrameExponent; }

void put_i24(uint8_t* p, int32_t v) {
  const uint32_t u = uint32_t(v) & 0xffffffu;
  p[0] = uint8_t(u);
  p[1] = uint8_t(u >> 8);
  p[2] = uint8_t(u >> 16);
}
uint32_t get_u24(const uint8_t* p) { return uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16; }
int32_t get_i24(const uint8_t* p) {
  const uint32_t u = get_u24(p);
  return int32_t(u ^ 0x800000u) - 0x800000;
}
}  // namespace

LeafFrame RoundedFrame::frame() const {
  const float step = pow2f(exponent);
  return {{float(k[0]) * step, float(k[1]) * step, float(k[2]) * step}, float(m) * step};
}

RoundedFrame round_frame_outward(const LeafFrame& f, int grid_bits) {
  const float largest = std::max({std::abs(f.center.x), std::abs(f.center.y), std::abs(f.center.z)});
  int e = std::max({ilogb_or_min(f.radius) - grid_bits, ilogb_or_min(largest) - kFrameCenterBits, kMinFrameExponent});
  for (;; ++e) {
    if (e > kMaxFrameExponent) {
      throw InvalidArgument("a leaf frame of radius " + std::to_string(f.radius) + " is too large for a rounded frame");
    }
    RoundedFrame r;
    r.exponent = e;
    const float down = pow2f(-e);  // e >= -126: 2^-e <= 2^126, a float
    double moved2 = 0;
    for (int a = 0; a < 3; ++a) {
      // |c| < 2^(ilogb + 1) <= 2^(e + 22): c 2^-e is exact and below 2^22.
      r.k[a] = int32_t(std::rint(f.center[a] * down));
      const double d = double(f.center[a]) - double(r.k[a]) * double(pow2f(e));
      moved2 += d * d;
    }
    // The radius, widened by the centre's move, rounded up to the grid (in
    // double: exact for the steps and sizes here, and never below).
    const double need = (double(f.radius) + std::sqrt(moved2)) * double(down);
    const double m = std::ceil(need);
    if (m > double(kMaxRoundedFrameRadius)) continue;  // a coarser grid
    r.m = uint32_t(m);
    return r;
  }
}

namespace {
// The exponent of the lowest set bit of a non-zero finite float.
int lowest_bit_exponent(float v) {
  const uint32_t bits = std::bit_cast<uint32_t>(v) & 0x7fffffffu;
  const int biased = int(bits >> 23);
  const uint32_t mantissa = (bits & 0x7fffffu) | (biased != 0 ? 0x800000u : 0u);
  return (biased != 0 ? biased - 127 - 23 : -126 - 23) + std::countr_zero(mantissa);
}
}  // namespace

bool to_rounded_frame(const LeafFrame& f, RoundedFrame& out) {
  const float v[4] = {f.center.x, f.center.y, f.center.z, f.radius};
  // The coarsest grid on which all four are integers: the smallest k and m.
  int e = kMaxFrameExponent;
  for (float x : v) {
    if (!std::isfinite(x)) return false;
    if (x != 0.f) e = std::min(e, lowest_bit_exponent(x));
  }
  if (e < kMinFrameExponent || f.radius < 0.f) return false;
  const float down = pow2f(-e);
  out.exponent = e;
  for (int a = 0; a < 3; ++a) {
    const float k = v[a] * down;  // an integer: exact
    if (std::abs(k) > float(kMaxRoundedFrameCenter)) return false;
    out.k[a] = int32_t(k);
  }
  const float m = f.radius * down;
  if (m > float(kMaxRoundedFrameRadius)) return false;
  out.m = uint32_t(m);
  return true;
}

namespace {
// The 12-byte sphere of a compact link record: a rounded frame with m in a u16.
void write_sphere(const LeafFrame& f, uint8_t* out) {
  RoundedFrame r;
  if (!to_rounded_frame(f, r)) throw Error("internal: a link record for a sphere that is not rounded");
  out[0] = uint8_t(r.exponent + kFrameExponentBias);
  for (int a = 0; a < 3; ++a) put_i24(out + 1 + 3 * std::ptrdiff_t(a), r.k[a]);
  store_le<uint16_t>(out + 10, uint16_t(r.m));
}
bool read_sphere(const uint8_t* in, LeafFrame& f) {
  RoundedFrame r;
  r.exponent = int(in[0]) - kFrameExponentBias;
  if (r.exponent < kMinFrameExponent || r.exponent > kMaxFrameExponent) return false;
  for (int a = 0; a < 3; ++a) {
    r.k[a] = get_i24(in + 1 + 3 * std::ptrdiff_t(a));
    if (std::abs(r.k[a]) > kMaxRoundedFrameCenter) return false;
  }
  r.m = load_le<uint16_t>(in + 10);
  if (r.m > kMaxRoundedFrameRadius) return false;
  f = r.frame();
  return std::isfinite(f.center.x) && std::isfinite(f.center.y) && std::isfinite(f.center.z);
}
}  // namespace

void write_compact_link_record(uint32_t page, const tree::Node& n, uint8_t* out) {
  store_le<uint32_t>(out, page);                // 0
  write_sphere({n.center, n.radius}, out + 4);  // 4
  uint32_t axis = 0;
  uint16_t one_minus_cos = 0;
  if (!tree::cone_code({n.cone_axis, n.cone_cos}, axis, one_minus_cos)) {
    throw Error("internal: a link record for a cone that is not rounded");
  }
  store_le<uint32_t>(out + 16, axis);           // 16
  store_le<uint16_t>(out + 20, one_minus_cos);  // 20
  store_le<float>(out + 22, n.area);            // 22
}

bool read_compact_link_record(const uint8_t* in, uint32_t& page, tree::Node& n) {
  page = load_le<uint32_t>(in);
  LeafFrame sphere;
  if (!read_sphere(in + 4, sphere)) return false;
  tree::NormalCone cone;
  if (!tree::cone_of_code(load_le<uint32_t>(in + 16), load_le<uint16_t>(in + 20), cone)) return false;
  const auto area = load_le<float>(in + 22);
  if (!(area >= 0.f) || !std::isfinite(area)) return false;
  n.center = sphere.center;
  n.radius = sphere.radius;
  n.cone_axis = cone.axis;
  n.cone_cos = cone.cos_half_angle;
  n.area = area;
  return true;
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

LeafFormat parse_leaf_format(const std::string& name) {
  if (const auto format = options::parse_enum<LeafFormat>(name)) return *format;
  throw InvalidArgument("leaf_format '" + name + "' is not one of: " + options::enum_name_list<LeafFormat>());
}

std::string to_string(LeafFormat format) {
  const std::string_view name = options::enum_name(format);
  return std::string(name.empty() ? options::enum_name(LeafFormat::kRelative) : name);  // a bad number, as before
}

namespace {
void encode_relative(const Surfel& s, const LeafFrame& f, uint8_t* out) {
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

void decode_relative(const uint8_t* in, const LeafFrame& f, Surfel& s) {
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

// Compact: bytes 0-9 are one 80-bit little-endian field (u64 at 0, u16 at
// 8): x, y, z 14-bit offset-binary snorm at bits 0, 14, 28; octahedral
// normal 2 x 12 bits at 42 (u) and 54 (v); radius 13-bit unorm at 66;
// "emits" at 79. Then albedo (10) and radiance (14), RGB9E5.
constexpr int kCompactPositionBits = 14;
constexpr int kCompactNormalBits = 12;
constexpr int kCompactRadiusBits = 13;

// A position coordinate (offset from the frame's centre over its radius) as
// a 14-bit code on the grid 8191 + 2^shift j, |j| <= 8191 >> shift: shift 0
// is the 14-bit snorm code; V10/V11 surfel sections store a page's codes in
// 14 - shift bits when all lie on such a grid (surfel_section.h).
uint32_t encode_grid_position(float x, int shift) {
  constexpr int kTop = (1 << (kCompactPositionBits - 1)) - 1;  // 8191
  const long steps = long(kTop >> shift);
  const long j = std::clamp(std::lround(std::clamp(x, -1.f, 1.f) * (float(kTop) / float(1 << shift))), -steps, steps);
  return uint32_t(kTop + (j << shift));
}

void encode_compact(const Surfel& s, const LeafFrame& f, uint8_t* out, int shift) {
  const float inv = f.radius > 0.f ? 1.f / f.radius : 0.f;
  const Imath::V3f d = (s.position - f.center) * inv;
  const uint64_t oct = encode_octahedral_bits(s.normal, kCompactNormalBits);  // 24 bits
  const uint64_t lo = uint64_t(encode_grid_position(d.x, shift)) | uint64_t(encode_grid_position(d.y, shift)) << 14 |
                      uint64_t(encode_grid_position(d.z, shift)) << 28 | oct << 42;
  const uint32_t hi = uint32_t(oct >> 22) | encode_unorm_bits(s.radius * inv, kCompactRadiusBits) << 2 |
                      (encode_rgb9e5(s.emission) != 0 ? 1u << 15 : 0u);
  store_le<uint64_t>(out, lo);
  store_le<uint16_t>(out + 8, uint16_t(hi));
  store_le<uint32_t>(out + 10, encode_rgb9e5(s.albedo));
  store_le<uint32_t>(out + 14, encode_rgb9e5(s.radiance));
}

// `shared`: the record without albedo (radiance at 10).
void decode_compact(const uint8_t* in, const LeafFrame& f, Surfel& s, bool shared = false) {
  const uint64_t lo = load_le<uint64_t>(in);
  const uint32_t hi = load_le<uint16_t>(in + 8);
  constexpr uint64_t kPos = (1u << kCompactPositionBits) - 1u;
  const float R = f.radius;
  s.position.x = f.center.x + R * decode_snorm_bits(uint32_t(lo & kPos), kCompactPositionBits);
  s.position.y = f.center.y + R * decode_snorm_bits(uint32_t((lo >> 14) & kPos), kCompactPositionBits);
  s.position.z = f.center.z + R * decode_snorm_bits(uint32_t((lo >> 28) & kPos), kCompactPositionBits);
  const uint32_t oct = uint32_t(lo >> 42) | (hi & 3u) << 22;
  s.normal = decode_octahedral_bits(oct, kCompactNormalBits);
  s.radius = R * decode_unorm_bits((hi >> 2) & ((1u << kCompactRadiusBits) - 1u), kCompactRadiusBits);
  s.albedo = shared ? Imath::C3f(0.f, 0.f, 0.f) : decode_rgb9e5(load_le<uint32_t>(in + 10));  // shared: the page's
  s.emission = Imath::C3f(0.f, 0.f, 0.f);  // from the emission section, if the record emits
  s.radiance = decode_rgb9e5(load_le<uint32_t>(in + (shared ? 10 : 14)));
}

// Half floats. NaN never reaches here (surfel_checks refuses it); values
// past half's range clamp to its largest finite value rather than turn
// into infinities.
inline uint16_t half_bits(float v) {
  constexpr float kHalfMax = 65504.f;
  return Imath::half(std::clamp(v, -kHalfMax, kHalfMax)).bits();
}
inline float from_half_bits(uint16_t bits) {
  Imath::half h;
  h.setBits(bits);
  return float(h);
}
inline void put_half3(uint8_t* p, float x, float y, float z) {
  store_le<uint16_t>(p, half_bits(x));
  store_le<uint16_t>(p + 2, half_bits(y));
  store_le<uint16_t>(p + 4, half_bits(z));
}
template <typename V>
inline void get_half3(const uint8_t* p, V& v) {
  v.x = from_half_bits(load_le<uint16_t>(p));
  v.y = from_half_bits(load_le<uint16_t>(p + 2));
  v.z = from_half_bits(load_le<uint16_t>(p + 4));
}
inline Imath::C3f non_negative(const Imath::C3f& c) {
  return {std::max(c.x, 0.f), std::max(c.y, 0.f), std::max(c.z, 0.f)};
}

void encode_half(const Surfel& s, const LeafFrame& f, uint8_t* out) {
  put3(out, s.position.x, s.position.y, s.position.z);       // 0
  put_half3(out + 12, s.normal.x, s.normal.y, s.normal.z);   // 12
  // The radius as a fraction of the frame's: half's relative precision
  // then holds for any scene scale (an absolute half would overflow past
  // 65504 units and flush radii below 6e-8 to zero).
  store_le<uint16_t>(out + 18, half_bits(f.radius > 0.f ? s.radius / f.radius : 0.f));  // 18
  const Imath::C3f a = non_negative(s.albedo), e = non_negative(s.emission), r = non_negative(s.radiance);
  put_half3(out + 20, a.x, a.y, a.z);  // 20
  put_half3(out + 26, e.x, e.y, e.z);  // 26
  put_half3(out + 32, r.x, r.y, r.z);  // 32
}

void decode_half(const uint8_t* in, const LeafFrame& f, Surfel& s) {
  get3(in, s.position);
  Imath::V3f n;
  get_half3(in + 12, n);
  // Three half components are each within 2^-11 of a unit vector's: renormalize.
  const float len = n.length();
  s.normal = len > 0.f ? n / len : Imath::V3f(0, 0, 1);
  s.radius = f.radius * from_half_bits(load_le<uint16_t>(in + 18));
  get_half3(in + 20, s.albedo);
  get_half3(in + 26, s.emission);
  get_half3(in + 32, s.radiance);
}
}  // namespace

int position_grid_shift(float frame_radius, float smallest_radius) {
  // The largest shift whose step, 2^shift R / 8191, is at most r / 32:
  // 2^shift 32 R <= 8191 r, in double (exact for these products).
  int shift = 0;
  while (shift < kMaxPositionGridShift && double(1 << (shift + 1)) * kPositionStepsPerRadius * double(frame_radius) <=
                                              8191.0 * double(smallest_radius)) {
    ++shift;
  }
  return shift;
}

void encode_surfel_record(SurfelRecords records, const Surfel& s, const LeafFrame& f, uint8_t* out,
                          int position_shift) {
  switch (records) {
    case SurfelRecords::kHalf:
      return encode_half(s, f, out);
    case SurfelRecords::kCompact:
      return encode_compact(s, f, out, position_shift);
    case SurfelRecords::kCompactSharedAlbedo: {
      uint8_t full[kCompactSurfelRecordBytes];
      encode_compact(s, f, full, position_shift);
      return drop_albedo(full, out);
    }
    case SurfelRecords::kRelative:
      return encode_relative(s, f, out);
  }
}

void decode_surfel_record(SurfelRecords records, const uint8_t* in, const LeafFrame& f, Surfel& s) {
  switch (records) {
    case SurfelRecords::kHalf:
      return decode_half(in, f, s);
    case SurfelRecords::kCompact:
      return decode_compact(in, f, s);
    case SurfelRecords::kCompactSharedAlbedo:
      return decode_compact(in, f, s, true);
    case SurfelRecords::kRelative:
      return decode_relative(in, f, s);
  }
}

bool surfel_record_emits(SurfelRecords records, const uint8_t* in) {
  return emission_out_of_line(records) && (in[9] & 0x80u) != 0;
}

uint32_t compact_record_albedo(const uint8_t* compact) { return load_le<uint32_t>(compact + 10); }

void drop_albedo(const uint8_t* compact, uint8_t* out) {
  std::copy(compact, compact + 10, out);
  std::copy(compact + 14, compact + 18, out + 10);
}

void write_emission_entry(const Surfel& s, uint8_t* out) { store_le<uint32_t>(out, encode_rgb9e5(s.emission)); }

Imath::C3f read_emission_entry(const uint8_t* in) { return decode_rgb9e5(load_le<uint32_t>(in)); }

}  // namespace pbgi::storage
