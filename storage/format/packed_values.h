// Compact encodings of the values of a V2 surfel record, with their
// precision stated where they are defined (FORMAT.md repeats it):
//
//  * RGB9E5 shared-exponent colour (EXT_texture_shared_exponent): three
//    9-bit mantissas and one 5-bit exponent in 32 bits. Each channel is
//    within max(r, g, b) / 512 of its input (round to nearest); inputs are
//    clamped to [0, kRgb9e5Max]. Used for albedo, emission and radiance.
//  * Octahedral unit vector (Meyer et al. 2010, "On floating-point normal
//    vectors"), two 16-bit unsigned coordinates in 32 bits. The decoded
//    vector is within kOctahedralMaxAngle radians of the input.
//  * Signed and unsigned 16-bit fixed point for offsets within a frame.
//  * The same octahedral and fixed-point codes in fewer bits (the compact
//    surfel records of V6/V7 pages): octahedral 12 bits per coordinate,
//    within kOctahedral12MaxAngle radians; n-bit fixed point within half a
//    step (1 / (2^(n-1) - 1) signed, 1 / (2^n - 1) unsigned).
//
// Decoding is pure float arithmetic in a fixed order: the same bits always
// decode to the same floats, which the tree build relies on (it derives
// node bounds from the decoded values, exactly as a reader will).
//
// Thread-safety: pure functions.
#pragma once

#include <Imath/ImathColor.h>
#include <Imath/ImathVec.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>

namespace pbgi::storage {

// ---- RGB9E5 ----------------------------------------------------------------

inline constexpr int kRgb9e5MantissaBits = 9;
inline constexpr int kRgb9e5ExponentBias = 15;
inline constexpr int kRgb9e5MaxExponent = 31;
// (2^9 - 1) / 2^9 * 2^(31 - 15) = 65408: the largest encodable channel.
inline constexpr float kRgb9e5Max = 65408.f;

inline uint32_t encode_rgb9e5(const Imath::C3f& c) {
  // NaN and negatives become 0 (callers refuse them before; this only keeps
  // the encoder total).
  auto clampc = [](float v) { return v > 0.f ? std::min(v, kRgb9e5Max) : 0.f; };
  const float r = clampc(c.x), g = clampc(c.y), b = clampc(c.z);
  const float maxc = std::max(r, std::max(g, b));
  if (maxc <= 0.f) return 0;
  int e2 = 0;
  std::frexp(maxc, &e2);  // maxc = m * 2^e2, m in [0.5, 1): floor(log2 maxc) = e2 - 1
  // Exponent so that maxc's mantissa fits 9 bits; one more if rounding
  // would carry into a 10th bit. maxc <= kRgb9e5Max keeps it <= 31.
  int exp = std::max(-kRgb9e5ExponentBias - 1, e2 - 1) + 1 + kRgb9e5ExponentBias;
  double scale = std::ldexp(1.0, kRgb9e5MantissaBits + kRgb9e5ExponentBias - exp);
  if (std::floor(double(maxc) * scale + 0.5) >= double(1 << kRgb9e5MantissaBits)) {
    ++exp;
    scale *= 0.5;
  }
  auto mant = [&](float v) {
    return std::min<uint32_t>(uint32_t(std::floor(double(v) * scale + 0.5)), 511u);
  };
  return mant(r) | mant(g) << 9 | mant(b) << 18 | uint32_t(exp) << 27;
}

inline Imath::C3f decode_rgb9e5(uint32_t v) {
  // 2^(exp - 24), exp in [0, 31]: always a normal float, built from its bits.
  const int exp = int(v >> 27);
  const float scale = std::bit_cast<float>(uint32_t(exp - kRgb9e5ExponentBias - kRgb9e5MantissaBits + 127) << 23);
  return {float(v & 511u) * scale, float((v >> 9) & 511u) * scale, float((v >> 18) & 511u) * scale};
}

// ---- Octahedral unit vectors -----------------------------------------------

// Largest angle between a unit vector and its decoded encoding (measured
// over 10^7 directions by tests/storage/format; the bound holds with margin).
inline constexpr float kOctahedralMaxAngle = 1e-4f;

// The octahedral code with `bits` (2..16) bits per coordinate: u | v << bits.
inline uint32_t encode_octahedral_bits(const Imath::V3f& n, int bits) {
  const float l1 = std::abs(n.x) + std::abs(n.y) + std::abs(n.z);
  float u = l1 > 0.f ? n.x / l1 : 0.f, v = l1 > 0.f ? n.y / l1 : 0.f;
  if (n.z < 0.f) {
    const float fu = (1.f - std::abs(v)) * (u >= 0.f ? 1.f : -1.f);
    const float fv = (1.f - std::abs(u)) * (v >= 0.f ? 1.f : -1.f);
    u = fu;
    v = fv;
  }
  const float top = float((1u << bits) - 1u);
  auto q = [&](float x) { return uint32_t(std::lround(std::clamp((x * 0.5f + 0.5f) * top, 0.f, top))); };
  return q(u) | q(v) << bits;
}

inline Imath::V3f decode_octahedral_bits(uint32_t code, int bits) {
  const uint32_t mask = (1u << bits) - 1u;
  const float step = 2.f / float(mask);
  const float u = float(code & mask) * step - 1.f;
  const float v = float((code >> bits) & mask) * step - 1.f;
  Imath::V3f n(u, v, 1.f - std::abs(u) - std::abs(v));
  const float t = std::max(-n.z, 0.f);
  n.x += n.x >= 0.f ? -t : t;
  n.y += n.y >= 0.f ? -t : t;
  return n / n.length();
}

// 16 bits per coordinate (the V4/V5 surfel record's normal).
inline uint32_t encode_octahedral(const Imath::V3f& n) { return encode_octahedral_bits(n, 16); }
inline Imath::V3f decode_octahedral(uint32_t bits) { return decode_octahedral_bits(bits, 16); }

// Largest angle between a unit vector and its decoded 12-bit encoding
// (measured over 10^7 directions by tests/storage/format, with margin).
inline constexpr float kOctahedral12MaxAngle = 1.2e-3f;

// ---- Fixed point -----------------------------------------------------------

// x in [-1, 1] -> an unsigned `bits`-bit code (offset binary: q + 2^(bits-1)
// - 1 for q in [-(2^(bits-1) - 1), 2^(bits-1) - 1]), round to nearest.
inline uint32_t encode_snorm_bits(float x, int bits) {
  const int top = (1 << (bits - 1)) - 1;
  return uint32_t(std::lround(std::clamp(x, -1.f, 1.f) * float(top)) + top);
}
inline float decode_snorm_bits(uint32_t q, int bits) {
  const int top = (1 << (bits - 1)) - 1;
  return float(int(q) - top) * (1.f / float(top));
}

// x in [0, 1] -> [0, 2^bits - 1], round to nearest.
inline uint32_t encode_unorm_bits(float x, int bits) {
  const float top = float((1u << bits) - 1u);
  return uint32_t(std::lround(std::clamp(x, 0.f, 1.f) * top));
}
inline float decode_unorm_bits(uint32_t q, int bits) { return float(q) * (1.f / float((1u << bits) - 1u)); }

// x in [-1, 1] -> int16 in [-32767, 32767], round to nearest.
inline int16_t encode_snorm16(float x) {
  return int16_t(std::lround(std::clamp(x, -1.f, 1.f) * 32767.f));
}
inline float decode_snorm16(int16_t q) { return float(q) * (1.f / 32767.f); }

// x in [0, 1] -> uint16 in [0, 65535], round to nearest.
inline uint16_t encode_unorm16(float x) {
  return uint16_t(std::lround(std::clamp(x, 0.f, 1.f) * 65535.f));
}
inline float decode_unorm16(uint16_t q) { return float(q) * (1.f / 65535.f); }

}  // namespace pbgi::storage
