#include "server/scene/texture.h"

#include "common/errors.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace pbgi {
namespace {

using Imath::V4f;

// Texel index along one axis of `size` texels after wrapping; -1 = black.
int64_t wrap_index(int64_t i, int64_t size, TextureWrap wrap) {
  if (i >= 0 && i < size) return i;
  switch (wrap) {
    case TextureWrap::Black: return -1;
    case TextureWrap::Clamp: return std::clamp<int64_t>(i, 0, size - 1);
    case TextureWrap::Mirror: {
      const int64_t period = 2 * size;
      int64_t m = i % period;
      if (m < 0) m += period;
      return m < size ? m : period - 1 - m;
    }
    case TextureWrap::UseMetadata:
    case TextureWrap::Repeat: {
      const int64_t m = i % size;
      return m < 0 ? m + size : m;
    }
  }
  return -1;
}

// Next pyramid level: each texel averages the 2x2 block above it; an odd
// last row or column is folded into the previous block (a 3-wide average),
// so that every source texel counts. Blocks of unequal size then weigh
// their texels slightly differently; the 1x1 top level is set to the exact
// mean afterwards.
std::vector<float> downsample(const std::vector<float>& src, uint32_t w, uint32_t h, uint32_t* nw,
                              uint32_t* nh) {
  *nw = std::max(1u, w / 2);
  *nh = std::max(1u, h / 2);
  std::vector<float> dst(size_t(*nw) * *nh * 4, 0.f);
  auto span = [](uint32_t i, uint32_t n, uint32_t src_n, uint32_t* first, uint32_t* count) {
    *first = std::min(2 * i, src_n - 1);
    *count = (src_n == 1) ? 1 : 2;
    if (i == n - 1 && src_n > 2 * n) *count = src_n - *first;  // odd remainder
  };
  for (uint32_t y = 0; y < *nh; ++y) {
    uint32_t y0, ny;
    span(y, *nh, h, &y0, &ny);
    for (uint32_t x = 0; x < *nw; ++x) {
      uint32_t x0, nx;
      span(x, *nw, w, &x0, &nx);
      float* out = &dst[(size_t(y) * *nw + x) * 4];
      for (uint32_t yy = y0; yy < y0 + ny; ++yy)
        for (uint32_t xx = x0; xx < x0 + nx; ++xx)
          for (int c = 0; c < 4; ++c) out[c] += src[(size_t(yy) * w + xx) * 4 + c];
      const float inv = 1.f / float(nx * ny);
      for (int c = 0; c < 4; ++c) out[c] *= inv;
    }
  }
  return dst;
}

}  // namespace

Texture::Texture(std::string name, uint32_t width, uint32_t height, uint32_t channels,
                 const std::vector<float>& texels)
    : name_(std::move(name)) {
  if (width == 0 || height == 0 || channels < 1 || channels > 4 ||
      texels.size() != size_t(width) * height * channels) {
    throw InvalidArgument(fmt::format("texture '{}': {} values for {}x{} texels of {} channels",
                                      name_, texels.size(), width, height, channels));
  }
  // Expand to RGBA in float for the pyramid, then store half.
  std::vector<float> rgba(size_t(width) * height * 4);
  double sum[4] = {0, 0, 0, 0};
  for (size_t i = 0; i < size_t(width) * height; ++i) {
    const float* t = &texels[i * channels];
    float v[4];
    switch (channels) {
      case 1: v[0] = v[1] = v[2] = t[0]; v[3] = 1.f; break;
      case 2: v[0] = v[1] = v[2] = t[0]; v[3] = t[1]; break;
      case 3: v[0] = t[0]; v[1] = t[1]; v[2] = t[2]; v[3] = 1.f; break;
      default: v[0] = t[0]; v[1] = t[1]; v[2] = t[2]; v[3] = t[3]; break;
    }
    for (int c = 0; c < 4; ++c) {
      // Non-finite texels would poison every filtered value around them.
      if (!std::isfinite(v[c])) v[c] = 0.f;
      // Half tops out at 65504; larger HDR values are clamped, not inf.
      v[c] = std::clamp(v[c], -65504.f, 65504.f);
      rgba[i * 4 + c] = v[c];
      sum[c] += v[c];
    }
  }
  const double n = double(width) * height;
  mean_ = V4f(float(sum[0] / n), float(sum[1] / n), float(sum[2] / n), float(sum[3] / n));

  uint32_t w = width, h = height;
  for (;;) {
    Level level;
    level.width = w;
    level.height = h;
    level.rgba.assign(rgba.begin(), rgba.end());
    levels_.push_back(std::move(level));
    if (w == 1 && h == 1) break;
    uint32_t nw, nh;
    rgba = downsample(rgba, w, h, &nw, &nh);
    w = nw;
    h = nh;
  }
  for (int c = 0; c < 4; ++c) levels_.back().rgba[c] = Imath::half(mean_[c]);
}

size_t Texture::memory_bytes() const {
  size_t bytes = 0;
  for (const Level& l : levels_) bytes += l.rgba.size() * sizeof(Imath::half);
  return bytes;
}

V4f Texture::texel(uint32_t x, uint32_t y) const {
  const Level& l = levels_[0];
  const Imath::half* t = &l.rgba[(size_t(std::min(y, l.height - 1)) * l.width + std::min(x, l.width - 1)) * 4];
  return V4f(t[0], t[1], t[2], t[3]);
}

V4f Texture::fetch(const Level& level, int64_t x, int64_t y, TextureWrap ws, TextureWrap wt) const {
  const int64_t xi = wrap_index(x, level.width, ws);
  const int64_t yi = wrap_index(y, level.height, wt);
  if (xi < 0 || yi < 0) return V4f(0.f, 0.f, 0.f, 0.f);
  const Imath::half* t = &level.rgba[(size_t(yi) * level.width + size_t(xi)) * 4];
  return V4f(t[0], t[1], t[2], t[3]);
}

V4f Texture::bilinear(const Level& level, const V2f& st, TextureWrap ws, TextureWrap wt) const {
  // t = 0 is the bottom row; texel centres sit at half-integers.
  const double x = double(st.x) * level.width - 0.5;
  const double y = (1.0 - double(st.y)) * level.height - 0.5;
  const double fx = std::floor(x), fy = std::floor(y);
  const float ax = float(x - fx), ay = float(y - fy);
  const int64_t x0 = int64_t(fx), y0 = int64_t(fy);
  const V4f a = fetch(level, x0, y0, ws, wt), b = fetch(level, x0 + 1, y0, ws, wt);
  const V4f c = fetch(level, x0, y0 + 1, ws, wt), d = fetch(level, x0 + 1, y0 + 1, ws, wt);
  return (a * (1.f - ax) + b * ax) * (1.f - ay) + (c * (1.f - ax) + d * ax) * ay;
}

V4f Texture::lookup(const V2f& st, TextureWrap wrap_s, TextureWrap wrap_t, float footprint) const {
  if (!std::isfinite(st.x) || !std::isfinite(st.y)) return mean_;
  // Level whose texels are about `footprint` wide.
  const float texels = footprint * float(std::max(width(), height()));
  const float lod = texels > 1.f ? std::log2(texels) : 0.f;
  const float top = float(levels_.size() - 1);
  if (!(lod < top)) return bilinear(levels_.back(), st, wrap_s, wrap_t);
  const size_t l0 = size_t(lod);
  const float f = lod - float(l0);
  const V4f v0 = bilinear(levels_[l0], st, wrap_s, wrap_t);
  if (f == 0.f) return v0;
  return v0 * (1.f - f) + bilinear(levels_[l0 + 1], st, wrap_s, wrap_t) * f;
}

namespace {

C3f select(const TextureBinding& b, const V4f& v) {
  C3f c(0.f, 0.f, 0.f);
  switch (b.channel) {
    case TextureChannel::Rgb: c = C3f(v.x, v.y, v.z); break;
    case TextureChannel::R: c = C3f(v.x); break;
    case TextureChannel::G: c = C3f(v.y); break;
    case TextureChannel::B: c = C3f(v.z); break;
    case TextureChannel::A: c = C3f(v.w); break;
  }
  return c * b.scale + b.bias;
}

}  // namespace

C3f evaluate_texture(const TextureBinding& binding, const V2f& st, float footprint) {
  V2f mapped;
  binding.st_transform.multVecMatrix(binding.uses_uvs ? st : binding.constant_st, mapped);
  return select(binding, binding.texture->lookup(mapped, binding.wrap_s, binding.wrap_t, footprint));
}

C3f evaluate_texture_mean(const TextureBinding& binding) {
  if (!binding.uses_uvs) return evaluate_texture(binding, binding.constant_st);
  return select(binding, binding.texture->mean());
}

}  // namespace pbgi
