#include "storage/tree/payload_rounding.h"

#include "storage/format/byte_order.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>

namespace pbgi::tree {

namespace {

constexpr int kBlock = sh::kCoeffs;
constexpr int kMantissaMax = 32767;
// Exponents are stored biased by 128 in a byte; blocks below 2^-100 are
// zero, so e >= -114 and every rounded value (q 2^e, |q| <= 32767) is a
// normal float, exactly representable, whatever the block.
constexpr int kExponentBias = 128;
constexpr int kMinExponent = -114;
constexpr int kMaxExponent = 114;  // a block near FLT_MAX (2^128)

std::array<float*, 4> blocks(Node& n) {
  return {n.radiance_sh.r.data(), n.radiance_sh.g.data(), n.radiance_sh.b.data(), n.coverage_sh.data()};
}
std::array<const float*, 4> blocks(const Node& n) {
  return {n.radiance_sh.r.data(), n.radiance_sh.g.data(), n.radiance_sh.b.data(), n.coverage_sh.data()};
}

// 2^e as a float, built from its bits (e in [kMinExponent, kMaxExponent]:
// always a normal float). Scaling by it is exact, unlike a division, and
// far cheaper than ldexp: payloads are rounded for every node a page
// derives when it loads.
float pow2(int e) { return std::bit_cast<float>(uint32_t(e + 127) << 23); }

// The exponent of a block whose largest magnitude is `m` (>= 2^-100, finite:
// a normal float).
int block_exponent(float m) {
  const int k = int((std::bit_cast<uint32_t>(m) >> 23) & 255u) - 126;  // m in [2^(k-1), 2^k)
  int e = k - 15;                                                      // m 2^-e < 2^15
  if (std::rint(m * pow2(-e)) > float(kMantissaMax)) ++e;
  return e;
}

// std::rint(x) for |x| <= 2^22 in the default rounding mode (ties to
// even), with no branch: on baseline x86-64 std::rint inlines as a range
// test and a jump per value, and round_payload ran value by value (8% of
// loading a page). 1.5 * 2^23 + |x| lies where floats are the integers,
// so the sum rounds |x| to an integer, ties to even (1.5 * 2^23 is even),
// and the subtraction is exact; the sign is put back, so that -0.3 rounds
// to -0 as with rint. The compiler may not reassociate the sum away
// (no -ffast-math).
inline float rint_small(float x) {
  constexpr float kMagic = 12582912.f;  // 1.5 * 2^23
  return std::copysign((std::abs(x) + kMagic) - kMagic, x);
}

float block_max(const float* v) {
  float m = 0.f;
  for (int i = 0; i < kBlock; ++i) m = std::max(m, std::abs(v[i]));
  return m;
}

}  // namespace

void round_payload(Node& n) {
  for (float* v : blocks(n)) {
    const float m = block_max(v);
    if (!(m >= 0x1p-100f) || !std::isfinite(m)) {
      // Tiny blocks are zero; a non-finite one (never built: surfels are
      // checked) is left alone rather than hidden.
      if (std::isfinite(m)) std::fill(v, v + kBlock, 0.f);
      continue;
    }
    // Round to nearest (ties to even) in the default rounding mode: x 2^-e
    // is exact (or below 0.5 when it underflows), so is q 2^e.
    const int e = block_exponent(m);
    const float down = pow2(-e), up = pow2(e);
    for (int i = 0; i < kBlock; ++i) v[i] = rint_small(v[i] * down) * up;  // |v[i] down| <= 32767.5
  }
}

void write_rounded_payload(const Node& n, uint8_t* out) {
  for (const float* v : blocks(n)) {
    const float m = block_max(v);
    // A rounded block is zero or has m >= 2^-100 (round_payload).
    const int e = m >= 0x1p-100f && std::isfinite(m) ? block_exponent(m) : kMinExponent;
    *out++ = uint8_t(e + kExponentBias);
    const float down = pow2(-e);
    for (int i = 0; i < kBlock; ++i) {
      storage::store_le<uint16_t>(out, uint16_t(int16_t(rint_small(v[i] * down))));
      out += 2;
    }
  }
}

void write_compact_payload(const Node& n, std::vector<uint8_t>& out) {
  for (const float* v : blocks(n)) {
    const float m = block_max(v);
    if (!(m >= 0x1p-100f) || !std::isfinite(m)) {
      out.push_back(0);  // a zero block (rounded payloads have no other small ones)
      continue;
    }
    const int e = block_exponent(m);
    out.push_back(uint8_t(e + kExponentBias));
    const float down = pow2(-e);
    int16_t q[kBlock];
    uint32_t classes = 0;
    for (int i = 0; i < kBlock; ++i) {
      q[i] = int16_t(rint_small(v[i] * down));
      const uint32_t c = q[i] == 0 ? 0u : (q[i] >= -128 && q[i] <= 127) ? 1u : 2u;
      classes |= c << (2 * i);
    }
    out.push_back(uint8_t(classes));
    out.push_back(uint8_t(classes >> 8));
    out.push_back(uint8_t(classes >> 16));
    for (int i = 0; i < kBlock; ++i) {
      const uint32_t c = (classes >> (2 * i)) & 3u;
      if (c == 1) out.push_back(uint8_t(int8_t(q[i])));
      if (c == 2) {
        out.push_back(uint8_t(uint16_t(q[i])));
        out.push_back(uint8_t(uint16_t(q[i]) >> 8));
      }
    }
  }
}

size_t read_compact_payload(std::span<const uint8_t> in, Node& n) {
  size_t at = 0;
  for (float* v : blocks(n)) {
    if (at >= in.size()) return 0;
    const uint8_t x = in[at++];
    if (x == 0) {
      std::fill(v, v + kBlock, 0.f);
      continue;
    }
    const int e = int(x) - kExponentBias;
    if (e < kMinExponent || e > kMaxExponent || at + 3 > in.size()) return 0;
    const uint32_t classes = uint32_t(in[at]) | uint32_t(in[at + 1]) << 8 | uint32_t(in[at + 2]) << 16;
    at += 3;
    if ((classes >> 18) != 0 || classes == 0) return 0;  // spare bits; a zero block has its own byte
    const float up = pow2(e);
    for (int i = 0; i < kBlock; ++i) {
      const uint32_t c = (classes >> (2 * i)) & 3u;
      int q = 0;
      if (c == 1) {
        if (at + 1 > in.size()) return 0;
        q = int(in[at]) - (in[at] >= 128u ? 256 : 0);  // two's complement byte
        ++at;
        if (q == 0) return 0;
      } else if (c == 2) {
        if (at + 2 > in.size()) return 0;
        q = int16_t(uint16_t(in[at]) | uint16_t(in[at + 1]) << 8);
        at += 2;
        if (q >= -128 && q <= 127) return 0;
      } else if (c == 3) {
        return 0;
      }
      v[i] = float(q) * up;
    }
  }
  return at;
}

bool read_rounded_payload(const uint8_t* in, sh::ShRgb& radiance, sh::Sh9& coverage) {
  for (float* v : {radiance.r.data(), radiance.g.data(), radiance.b.data(), coverage.data()}) {
    const int e = int(*in++) - kExponentBias;
    if (e < kMinExponent || e > kMaxExponent) return false;
    const float up = pow2(e);
    for (int i = 0; i < kBlock; ++i) {
      v[i] = float(int16_t(storage::load_le<uint16_t>(in))) * up;
      in += 2;
    }
  }
  return true;
}

bool read_rounded_payload(const uint8_t* in, Node& n) { return read_rounded_payload(in, n.radiance_sh, n.coverage_sh); }

}  // namespace pbgi::tree
