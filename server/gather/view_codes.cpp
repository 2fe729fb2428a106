#include "server/gather/view_codes.h"

#include <algorithm>
#include <bit>
#include <cmath>

namespace pbgi::gather {

namespace {
constexpr float kMax = 1e9f;  // below 16383 * 2^(62 - 46)
}  // namespace

Rgb48 encode_rgb48(const Imath::C3f& c) {
  Rgb48 out;
  uint64_t v = 0;
  if (std::isnan(c.x) || std::isnan(c.y) || std::isnan(c.z)) {
    v = uint64_t(kRgb48NanExponent) << 42;
  } else {
    auto clampc = [](float x) { return x > 0.f ? std::min(x, kMax) : 0.f; };
    const float r = clampc(c.x), g = clampc(c.y), b = clampc(c.z);
    const float maxc = std::max(r, std::max(g, b));
    if (maxc > 0.f) {
      // maxc < 2^e2 (frexp's exponent, from the bits for a normal float).
      const auto bits = std::bit_cast<uint32_t>(maxc);
      int e2 = int(bits >> 23) - 126;
      if ((bits >> 23) == 0) std::frexp(maxc, &e2);
      // maxc * 2^(46 - e) < 2^14 for e = e2 + 32; one more if rounding
      // carries. Scaling by a power of two is exact; the mantissas round to
      // nearest, ties up.
      int e = std::clamp(e2 + 32, 0, kRgb48NanExponent - 1);
      auto pow2 = [](int k) { return std::bit_cast<float>(uint32_t(k + 127) << 23); };
      float scale = pow2(46 - e);
      if (round_half_up(maxc * scale) >= 16384u) {
        ++e;
        scale = pow2(46 - e);
      }
      auto mant = [&](float x) { return uint64_t(std::min(round_half_up(x * scale), 16383u)); };
      v = mant(r) | mant(g) << 14 | mant(b) << 28 | uint64_t(e) << 42;
    }
  }
  out.w[0] = uint16_t(v);
  out.w[1] = uint16_t(v >> 16);
  out.w[2] = uint16_t(v >> 32);
  return out;
}

}  // namespace pbgi::gather
