#include "server/gather/view_codes.h"

#include <algorithm>
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
      int e2 = 0;
      std::frexp(maxc, &e2);  // maxc < 2^e2
      // maxc * 2^(46 - e) < 2^14 for e = e2 + 32; one more if rounding carries.
      int e = std::clamp(e2 + 32, 0, kRgb48NanExponent - 1);
      double scale = std::ldexp(1.0, 46 - e);
      if (std::nearbyint(double(maxc) * scale) >= 16384.0) {
        ++e;
        scale *= 0.5;
      }
      auto mant = [&](float x) { return uint64_t(std::min(std::nearbyint(double(x) * scale), 16383.0)); };
      v = mant(r) | mant(g) << 14 | mant(b) << 28 | uint64_t(e) << 42;
    }
  }
  out.w[0] = uint16_t(v);
  out.w[1] = uint16_t(v >> 16);
  out.w[2] = uint16_t(v >> 32);
  return out;
}

}  // namespace pbgi::gather
