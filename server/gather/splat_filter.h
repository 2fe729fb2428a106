// The filter a splat is drawn with (rasterizer.h): its equal-area rectangle
// of half widths h convolved with a box of half width c h, a trapezoid of
// support +-(1 + c) h; c = 1 (the default) gives a tent, c = 0 the box
// itself. Shared by the scalar rasterizer and the SIMD splat kernel
// (splat_kernels.h), which must evaluate it identically.
#pragma once

#ifndef PBGI_SPLAT_SMOOTH
#define PBGI_SPLAT_SMOOTH 1.f
#endif

namespace pbgi::gather {

inline constexpr float kSplatInvPi = 0.31830989f;
inline constexpr float kSplatSmooth = PBGI_SPLAT_SMOOTH;
// The ramp's 1 / 8AB in units of h.
inline constexpr float kSplatRampScale = kSplatSmooth > 0.f ? 1.f / (8.f * kSplatSmooth) : 0.f;

inline float splat_support(float h) { return (1.f + kSplatSmooth) * h; }

// CDF at x of the filter centered at 0, given inv = 1 / h, for x inside
// the support: a ramp (x + A + B)^2 / 8AB up to -(A - B), linear
// 1/2 + x/2A across the flat top, symmetric above (A = h, B = c h).
inline float splat_inner_cdf(float x, float inv) {
  const float t = x * inv;  // in units of h
  if constexpr (kSplatSmooth <= 0.f) return 0.5f + 0.5f * t;
  constexpr float k = kSplatRampScale;
  if (t < kSplatSmooth - 1.f) return k * (t + 1.f + kSplatSmooth) * (t + 1.f + kSplatSmooth);
  if (t > 1.f - kSplatSmooth) return 1.f - k * (1.f + kSplatSmooth - t) * (1.f + kSplatSmooth - t);
  return 0.5f + 0.5f * t;
}

// The same anywhere: 0 before the support, 1 after it.
inline float splat_tent_cdf(float x, float inv) {
  const float t = x * inv;
  if (t <= -1.f - kSplatSmooth) return 0.f;
  if (t >= 1.f + kSplatSmooth) return 1.f;
  return splat_inner_cdf(x, inv);
}

}  // namespace pbgi::gather
