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
    for (int i = 0; i < kBlock; ++i) v[i] = std::rint(v[i] * down) * up;
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
      storage::store_le<uint16_t>(out, uint16_t(int16_t(std::rint(v[i] * down))));
      out += 2;
    }
  }
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
