// The colour code a page view (page_views.h) keeps its nodes' mean
// radiance and its leaf surfels' radiance in, so that a cached page costs
// about three times its bytes on disk instead of four or five (issue 19;
// docs/out-of-core.md, "What a cached page costs").
//
// Rgb48: three 14-bit mantissas under one 6-bit exponent (RGB9E5's layout
// with more bits): each channel within max(r, g, b) / 16384 of its input
// for max(r, g, b) from 2^-33 (1.2e-10) to 1e9; below, within 2^-47. RGB9E5 values (the radiance of leaf surfels read
// from pages on disk) re-encode exactly. The code depends on the colour
// alone, so a node or surfel decodes to the same bits in any page.
//
// Thread-safety: pure functions.
#pragma once

#include <Imath/ImathColor.h>

#include <bit>
#include <cstdint>

namespace pbgi::gather {

struct Rgb48 {
  uint16_t w[3] = {0, 0, 0};
};

// The exponent that marks a colour with a NaN channel: it decodes to NaN in
// every channel, so that a NaN reaching a view still reaches the result,
// where the gather counts and replaces it (GatherCounters::non_finite)
// instead of showing the surface black.
inline constexpr int kRgb48NanExponent = 63;

// Negative channels become 0, infinite ones the largest value.
Rgb48 encode_rgb48(const Imath::C3f& c);

// t in [0, 2^23) rounded to the nearest integer, ties up, without a
// library call (views are built on every page cache miss). Exact: unlike
// uint32_t(t + 0.5f), which takes 0.5 - 2^-25 to 1 (the sum rounds up).
inline uint32_t round_half_up(float t) {
  const auto i = uint32_t(t);
  return i + (t - float(i) >= 0.5f ? 1u : 0u);
}

namespace detail {
// 2^(e - 46) for e in [0, 62] (normal floats, built from their bits); NaN for 63.
struct Rgb48Scales {
  float s[64];
  constexpr Rgb48Scales() : s() {
    for (int e = 0; e < 64; ++e) {
      s[e] = e == kRgb48NanExponent ? std::bit_cast<float>(0x7fc00000u)
                                    : std::bit_cast<float>(uint32_t(e - 46 + 127) << 23);
    }
  }
};
inline constexpr Rgb48Scales kRgb48Scales{};
}  // namespace detail

inline Imath::C3f decode_rgb48(const Rgb48& c) {
  const uint64_t v = uint64_t(c.w[0]) | uint64_t(c.w[1]) << 16 | uint64_t(c.w[2]) << 32;
  const float scale = detail::kRgb48Scales.s[v >> 42];
  return {float(v & 0x3fffu) * scale, float((v >> 14) & 0x3fffu) * scale, float((v >> 28) & 0x3fffu) * scale};
}

}  // namespace pbgi::gather
