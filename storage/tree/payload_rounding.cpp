#include "storage/tree/payload_rounding.h"

#include "storage/format/byte_order.h"

#include <array>
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
constexpr int kMaxExponent = 113;  // 2^128 > any float

std::array<float*, 4> blocks(Node& n) {
  return {n.radiance_sh.r.data(), n.radiance_sh.g.data(), n.radiance_sh.b.data(), n.coverage_sh.data()};
}
std::array<const float*, 4> blocks(const Node& n) {
  return {n.radiance_sh.r.data(), n.radiance_sh.g.data(), n.radiance_sh.b.data(), n.coverage_sh.data()};
}

// The exponent of a block whose largest magnitude is `m` (> 0, finite).
int block_exponent(float m) {
  int k = 0;
  std::frexp(m, &k);  // m in [2^(k-1), 2^k)
  int e = k - 15;     // m 2^-e < 2^15
  if (std::llround(std::ldexp(double(m), -e)) > kMantissaMax) ++e;
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
    const int e = block_exponent(m);
    for (int i = 0; i < kBlock; ++i) v[i] = float(std::ldexp(double(std::llround(std::ldexp(double(v[i]), -e))), e));
  }
}

void write_rounded_payload(const Node& n, uint8_t* out) {
  for (const float* v : blocks(n)) {
    const float m = block_max(v);
    const int e = m > 0.f && std::isfinite(m) ? block_exponent(m) : kMinExponent;
    *out++ = uint8_t(e + kExponentBias);
    for (int i = 0; i < kBlock; ++i) {
      storage::store_le<uint16_t>(out, uint16_t(int16_t(std::llround(std::ldexp(double(v[i]), -e)))));
      out += 2;
    }
  }
}

bool read_rounded_payload(const uint8_t* in, Node& n) {
  for (float* v : blocks(n)) {
    const int e = int(*in++) - kExponentBias;
    if (e < kMinExponent || e > kMaxExponent) return false;
    for (int i = 0; i < kBlock; ++i) {
      v[i] = float(std::ldexp(double(int16_t(storage::load_le<uint16_t>(in))), e));
      in += 2;
    }
  }
  return true;
}

}  // namespace pbgi::tree
