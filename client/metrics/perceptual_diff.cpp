#include "client/metrics/perceptual_diff.h"

#include "common/errors.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

namespace pbgi::metrics {
namespace {

constexpr int kLevels = 8;
constexpr int kBands = kLevels - 2;
constexpr double kPi = 3.14159265358979323846;

using Plane = std::vector<float>;

// Linear Rec.709 (D65) -> CIE XYZ.
void rgb_to_xyz(float r, float g, float b, float* x, float* y, float* z) {
  *x = 0.4123908f * r + 0.3575843f * g + 0.1804808f * b;
  *y = 0.2126390f * r + 0.7151687f * g + 0.0721923f * b;
  *z = 0.0193308f * r + 0.1191948f * g + 0.9505322f * b;
}

float lab_f(float t) {
  constexpr float d = 6.f / 29.f;
  return t > d * d * d ? std::cbrt(t) : t / (3.f * d * d) + 4.f / 29.f;
}

// One separable pass of the 5-tap kernel with taps `step` pixels apart,
// mirroring at the borders.
Plane blur(const Plane& in, uint32_t w, uint32_t h, int step) {
  static constexpr float k[5] = {0.05f, 0.25f, 0.4f, 0.25f, 0.05f};
  auto mirror = [](int i, int n) {
    // Reflect until inside: large steps on small images can overshoot twice.
    while (i < 0 || i >= n) i = i < 0 ? -i - 1 : 2 * n - i - 1;
    return i;
  };
  Plane tmp(in.size()), out(in.size());
  for (uint32_t y = 0; y < h; ++y)
    for (uint32_t x = 0; x < w; ++x) {
      float s = 0.f;
      for (int j = 0; j < 5; ++j) s += k[j] * in[size_t(y) * w + mirror(int(x) + (j - 2) * step, int(w))];
      tmp[size_t(y) * w + x] = s;
    }
  for (uint32_t y = 0; y < h; ++y)
    for (uint32_t x = 0; x < w; ++x) {
      float s = 0.f;
      for (int j = 0; j < 5; ++j) s += k[j] * tmp[size_t(mirror(int(y) + (j - 2) * step, int(h))) * w + x];
      out[size_t(y) * w + x] = s;
    }
  return out;
}

std::array<Plane, kLevels> pyramid(const Plane& base, uint32_t w, uint32_t h) {
  std::array<Plane, kLevels> levels;
  levels[0] = base;
  for (int l = 1; l < kLevels; ++l) levels[l] = blur(levels[l - 1], w, h, 1 << (l - 1));
  return levels;
}

// Threshold-versus-intensity, cd/m^2 (Ward Larson, Rushmeier, Piatko 1997).
double tvi(double adaptation) {
  const double log_a = std::log10(adaptation);
  double r;
  if (log_a < -3.94) r = -2.86;
  else if (log_a < -1.44) r = std::pow(0.405 * log_a + 1.6, 2.18) - 2.86;
  else if (log_a < -0.0184) r = log_a - 0.395;
  else if (log_a < 1.9) r = std::pow(0.249 * log_a + 0.65, 2.7) - 0.72;
  else r = log_a - 1.255;
  return std::pow(10.0, r);
}

// Barten's contrast sensitivity at `cpd` cycles/degree and luminance `lum`.
double csf(double cpd, double lum) {
  const double a = 440.0 * std::pow(1.0 + 0.7 / lum, -0.2);
  const double b = 0.3 * std::pow(1.0 + 100.0 / lum, 0.15);
  return a * cpd * std::exp(-b * cpd) * std::sqrt(1.0 + 0.06 * std::exp(b * cpd));
}

// Daly's visual masking.
double mask(double contrast) {
  const double a = std::pow(392.498 * contrast, 0.7);
  const double b = std::pow(0.0153 * a, 4.0);
  return std::pow(1.0 + b, 0.25);
}

struct Converted {
  Plane lum, a, b;  // luminance in cd/m^2, CIE a*, b*
};

Converted convert(const std::vector<float>& rgb, size_t n, float white_luminance) {
  float xw, yw, zw;
  rgb_to_xyz(1.f, 1.f, 1.f, &xw, &yw, &zw);
  Converted c;
  c.lum.resize(n);
  c.a.resize(n);
  c.b.resize(n);
  for (size_t i = 0; i < n; ++i) {
    float px[3];
    for (int k = 0; k < 3; ++k) {
      const float v = rgb[3 * i + k];
      px[k] = std::isfinite(v) ? v : 0.f;
    }
    float x, y, z;
    rgb_to_xyz(px[0], px[1], px[2], &x, &y, &z);
    c.lum[i] = std::max(0.f, y) * white_luminance;
    const float fx = lab_f(std::max(0.f, x) / xw), fy = lab_f(std::max(0.f, y) / yw),
                fz = lab_f(std::max(0.f, z) / zw);
    c.a[i] = 500.f * (fx - fy);
    c.b[i] = 200.f * (fy - fz);
  }
  return c;
}

Plane blur_to_level(Plane p, uint32_t w, uint32_t h, int level) {
  for (int l = 1; l <= level; ++l) p = blur(p, w, h, 1 << (l - 1));
  return p;
}

}  // namespace

PerceptualResult perceptual_diff(const std::vector<float>& test_rgb,
                                 const std::vector<float>& reference_rgb, uint32_t width,
                                 uint32_t height, const PerceptualOptions& options) {
  const size_t n = size_t(width) * height;
  if (width == 0 || height == 0 || test_rgb.size() != n * 3 || reference_rgb.size() != n * 3)
    throw InvalidArgument("perceptual_diff: expected " + std::to_string(n * 3) +
                          " floats per image for " + std::to_string(width) + "x" +
                          std::to_string(height) + ", got " + std::to_string(test_rgb.size()) +
                          " and " + std::to_string(reference_rgb.size()));
  if (!(options.field_of_view_degrees > 0.f && options.field_of_view_degrees < 180.f))
    throw InvalidArgument("PerceptualOptions.field_of_view_degrees must be in (0, 180)");
  if (!(options.white_luminance > 0.f))
    throw InvalidArgument("PerceptualOptions.white_luminance must be > 0");
  if (!(options.color_factor >= 0.f))
    throw InvalidArgument("PerceptualOptions.color_factor must be >= 0");

  // 1-2. Colour conversion and luminance pyramids.
  const Converted t = convert(test_rgb, n, options.white_luminance);
  const Converted r = convert(reference_rgb, n, options.white_luminance);
  const auto tl = pyramid(t.lum, width, height);
  const auto rl = pyramid(r.lum, width, height);

  // 3-4. Viewing geometry: frequencies of the bands, the adaptation level.
  const double fov = options.field_of_view_degrees * kPi / 180.0;
  const double degrees_across = 2.0 * std::tan(0.5 * fov) * 180.0 / kPi;
  const double ppd = double(width) / degrees_across;
  int adaptation_level = kLevels - 1;
  for (int l = 0; l < kLevels; ++l)
    if (double(1 << l) >= ppd) {
      adaptation_level = l;
      break;
    }
  std::array<double, kBands> cpd{}, f_freq{};
  const double csf_max = csf(3.248, 100.0);
  for (int l = 0; l < kBands; ++l) {
    cpd[l] = 0.5 * ppd / double(1 << l);
    f_freq[l] = csf_max / csf(cpd[l], 100.0);
  }

  // 8 (prep). Colour channels at the adaptation level's resolution of detail.
  const bool color_test = !options.luminance_only && options.color_factor > 0.f;
  Plane ta, tb, ra, rb;
  if (color_test) {
    ta = blur_to_level(t.a, width, height, adaptation_level);
    tb = blur_to_level(t.b, width, height, adaptation_level);
    ra = blur_to_level(r.a, width, height, adaptation_level);
    rb = blur_to_level(r.b, width, height, adaptation_level);
  }

  PerceptualResult result;
  result.pixels = n;
  if (options.want_map) result.map.assign(n, 0);
  for (size_t i = 0; i < n; ++i) {
    // 5. Band contrasts.
    std::array<double, kBands> contrast{};
    double sum_contrast = 0.0;
    for (int l = 0; l < kBands; ++l) {
      const double n1 = std::fabs(tl[l][i] - tl[l + 1][i]);
      const double n2 = std::fabs(rl[l][i] - rl[l + 1][i]);
      const double d = std::max({double(std::fabs(tl[l + 2][i])), double(std::fabs(rl[l + 2][i])), 1e-5});
      contrast[l] = std::max(n1, n2) / d;
      sum_contrast += contrast[l];
    }
    sum_contrast = std::max(sum_contrast, 1e-5);
    const double adapt =
        std::max(0.5 * (double(tl[adaptation_level][i]) + double(rl[adaptation_level][i])), 1e-5);

    // 6. Threshold elevation from frequency sensitivity and masking.
    double factor = 0.0;
    for (int l = 0; l < kBands; ++l)
      factor += contrast[l] * f_freq[l] * mask(contrast[l] * csf(cpd[l], adapt)) / sum_contrast;
    factor = std::clamp(factor, 1.0, 10.0);

    // 7-8. Luminance, then colour.
    bool differs = std::fabs(double(tl[0][i]) - double(rl[0][i])) > factor * tvi(adapt);
    if (!differs && color_test) {
      const double scale = options.color_factor * std::min(1.0, adapt / 10.0);
      const double da = ta[i] - ra[i], db = tb[i] - rb[i];
      differs = (da * da + db * db) * scale > factor;
    }
    if (differs) {
      ++result.pixels_different;
      if (options.want_map) result.map[i] = 1;
    }
  }
  result.fraction_different = double(result.pixels_different) / double(n);
  return result;
}

}  // namespace pbgi::metrics
