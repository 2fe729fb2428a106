#include "storage/codecs/sh_normalization.h"

#include "common/errors.h"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <string>

namespace pbgi::storage {

namespace {
constexpr int K = sh::kCoeffs;
constexpr float kFlush = 1e-30f;

inline float flush(float x) { return std::abs(x) < kFlush ? 0.f : x; }
}  // namespace

NormalizedPayload normalize_payload(const tree::Node& node, float w) {
  NormalizedPayload out;
  const sh::Sh9* rad[3] = {&node.radiance_sh.r, &node.radiance_sh.g, &node.radiance_sh.b};
  for (int c = 0; c < 3; ++c)
    for (float x : *rad[c])
      if (!std::isfinite(x)) return out;  // raw
  for (float x : node.coverage_sh)
    if (!std::isfinite(x)) return out;
  const float c0 = node.coverage_sh[0];
  if (!(c0 > FLT_MIN)) return out;

  const double s = (double(node.radiance_sh.r[0]) + node.radiance_sh.g[0] + node.radiance_sh.b[0]) / (3.0 * c0);
  if (!std::isfinite(s) || s > double(FLT_MAX)) return out;
  for (int i = 0; i < K; ++i) out.v[3 * K + i] = flush(w * node.coverage_sh[i]);
  if (!(s >= double(FLT_MIN))) {
    // Dark: grey pseudo-radiance so the vector looks like a real one.
    out.kind = PayloadKind::kDark;
    for (int c = 0; c < 3; ++c)
      for (int i = 0; i < K; ++i) out.v[c * K + i] = flush(node.coverage_sh[i]);
    return out;
  }
  out.kind = PayloadKind::kRegular;
  out.scale = float(s);
  const double inv = 1.0 / s;
  for (int c = 0; c < 3; ++c)
    for (int i = 0; i < K; ++i) out.v[c * K + i] = flush(float((*rad[c])[i] * inv));
  return out;
}

void denormalize_payload(const float* v, float scale, float w, tree::Node& node) {
  sh::Sh9* rad[3] = {&node.radiance_sh.r, &node.radiance_sh.g, &node.radiance_sh.b};
  for (int c = 0; c < 3; ++c)
    for (int i = 0; i < K; ++i) (*rad[c])[i] = scale * v[c * K + i];
  const float inv_w = 1.f / w;
  for (int i = 0; i < K; ++i) node.coverage_sh[i] = v[3 * K + i] * inv_w;
}

LogScaleQuantizer::LogScaleQuantizer(uint32_t bits, float lo, float hi) : bits_(bits), lo_(lo), hi_(hi) {
  if (bits < 4 || bits > 16) {
    throw InvalidArgument("scale_bits = " + std::to_string(bits) + ": must be in [4, 16]");
  }
  if (!std::isfinite(lo) || !std::isfinite(hi) || !(hi > lo) || lo < -200.f || hi > 200.f) {
    throw InvalidArgument("log2 scale range [" + std::to_string(lo) + ", " + std::to_string(hi) +
                          "] is not a finite, non-empty range inside [-200, 200]");
  }
  step_ = (double(hi) - lo) / double((1u << bits) - 3);
}

uint32_t LogScaleQuantizer::encode(float s) const {
  if (!(s > 0.f)) return 0;  // also NaN
  const double l = std::log2(double(s));
  if (l > hi_ + step_ * 0.5) return escape_code();
  if (l < lo_ - 1.0) return 0;
  const double t = std::round((l - lo_) / step_);
  const double last = double((1u << bits_) - 3);
  return 1u + uint32_t(std::clamp(t, 0.0, last));
}

float LogScaleQuantizer::decode(uint32_t code) const {
  if (code == 0 || code >= escape_code()) return 0.f;
  return float(std::exp2(double(lo_) + double(code - 1) * step_));
}

double LogScaleQuantizer::max_relative_error() const { return std::exp2(step_ * 0.5) - 1.0; }

}  // namespace pbgi::storage
