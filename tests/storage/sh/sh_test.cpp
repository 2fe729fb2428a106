// The SH basis against numerical integration over the sphere.
#include "storage/sh/sh.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <random>

namespace pbgi::sh {
namespace {

using Imath::V3f;
constexpr double kPiD = 3.14159265358979323846;

// Midpoint rule on a (cos theta, phi) grid: equal-area cells, so each
// sample has weight 4 pi / (rings * sectors).
constexpr int kRings = 400, kSectors = 800;

template <class F>
void for_each_direction(F&& f) {
  const double w = 4 * kPiD / (double(kRings) * kSectors);
  for (int i = 0; i < kRings; ++i) {
    const double z = 1.0 - 2.0 * (i + 0.5) / kRings;
    const double s = std::sqrt(std::max(0.0, 1.0 - z * z));
    for (int j = 0; j < kSectors; ++j) {
      const double phi = 2 * kPiD * (j + 0.5) / kSectors;
      f(V3f(float(s * std::cos(phi)), float(s * std::sin(phi)), float(z)), w);
    }
  }
}

// Least-squares projection of f onto the basis (the basis is orthonormal).
Sh9 project(const std::function<double(const V3f&)>& f) {
  std::array<double, kCoeffs> acc{};
  for_each_direction([&](const V3f& d, double w) {
    const Sh9 y = basis(d);
    const double v = f(d) * w;
    for (int i = 0; i < kCoeffs; ++i) acc[i] += v * y[i];
  });
  Sh9 out;
  for (int i = 0; i < kCoeffs; ++i) out[i] = float(acc[i]);
  return out;
}

V3f random_direction(std::mt19937& rng) {
  std::normal_distribution<float> g;
  return V3f(g(rng), g(rng), g(rng)).normalized();
}

TEST(Sh, BasisIsOrthonormal) {
  std::array<std::array<double, kCoeffs>, kCoeffs> gram{};
  for_each_direction([&](const V3f& d, double w) {
    const Sh9 y = basis(d);
    for (int i = 0; i < kCoeffs; ++i) {
      for (int j = 0; j < kCoeffs; ++j) gram[i][j] += w * y[i] * y[j];
    }
  });
  for (int i = 0; i < kCoeffs; ++i) {
    for (int j = 0; j < kCoeffs; ++j)
      EXPECT_NEAR(gram[i][j], i == j ? 1.0 : 0.0, 1e-4) << i << "," << j;
  }
}

TEST(Sh, ProjectedConstantEvaluatesToTheConstant) {
  const Sh9 c = project([](const V3f&) { return 2.5; });
  EXPECT_NEAR(c[0], 2.5 * std::sqrt(4 * kPiD), 1e-4);
  for (int i = 1; i < kCoeffs; ++i) EXPECT_NEAR(c[i], 0.f, 1e-4f) << i;
  std::mt19937 rng(1);
  for (int t = 0; t < 20; ++t) EXPECT_NEAR(dot(c, basis(random_direction(rng))), 2.5f, 1e-4f);
}

TEST(Sh, ClampedCosineIsTheProjectionOfMaxZeroCosine) {
  std::mt19937 rng(2);
  std::vector<V3f> axes = {V3f(0, 0, 1), V3f(1, 0, 0), V3f(0, -1, 0)};
  for (int t = 0; t < 5; ++t) axes.push_back(random_direction(rng));
  for (const V3f& n : axes) {
    const Sh9 numeric = project([&](const V3f& w) { return std::max(0.0, double(n.dot(w))); });
    const Sh9 lobe = clamped_cosine(n);
    for (int i = 0; i < kCoeffs; ++i)
      EXPECT_NEAR(lobe[i], numeric[i], 1e-3f) << "coeff " << i << " axis " << n;
  }
}

TEST(Sh, ClampedCosineIsCloseToTheCosineWhereItIsSmooth) {
  // 3 bands keep ~99% of the lobe's energy: the reconstruction is within
  // 0.1 of max(0, cos) everywhere (it rings most at the horizon, 0.094,
  // and at the pole, 0.0625).
  const V3f n = V3f(1, 2, -0.5f).normalized();
  const Sh9 lobe = clamped_cosine(n);
  std::mt19937 rng(3);
  for (int t = 0; t < 200; ++t) {
    const V3f w = random_direction(rng);
    EXPECT_NEAR(dot(lobe, basis(w)), std::max(0.f, n.dot(w)), 0.1f);
  }
  EXPECT_NEAR(dot(lobe, basis(n)), 1.0625f, 1e-4f);  // 1/4 + 1/2 + 5/16
}

TEST(Sh, BandEnergyIsRotationInvariant) {
  const Sh9 ref = clamped_cosine(V3f(0, 0, 1));
  std::mt19937 rng(4);
  for (int t = 0; t < 100; ++t) {
    const Sh9 f = clamped_cosine(random_direction(rng));
    for (int l = 0; l < kBands; ++l)
      EXPECT_NEAR(band_energy(f, l), band_energy(ref, l), 1e-4f) << l;
  }
  // And for a general function: a sum of lobes rotated as a whole.
  Sh9 a{}, b{};
  const V3f d1 = V3f(1, 0, 0), d2 = V3f(0, 0.6f, 0.8f);
  add_scaled(a, clamped_cosine(d1), 1.f);
  add_scaled(a, clamped_cosine(d2), 0.5f);
  // The same pair rotated by 90 degrees about z: (x, y, z) -> (-y, x, z).
  add_scaled(b, clamped_cosine(V3f(-d1.y, d1.x, d1.z)), 1.f);
  add_scaled(b, clamped_cosine(V3f(-d2.y, d2.x, d2.z)), 0.5f);
  for (int l = 0; l < kBands; ++l) EXPECT_NEAR(band_energy(a, l), band_energy(b, l), 1e-4f) << l;
}

TEST(Sh, RgbHelpersScaleEachChannel) {
  ShRgb f;
  const Sh9 lobe = clamped_cosine(V3f(0, 0, 1));
  add_scaled(f, lobe, Imath::C3f(1.f, 0.5f, 0.f));
  ShRgb g;
  add_scaled(g, f, 2.f);
  const Imath::C3f v = evaluate(g, basis(V3f(0, 0, 1)));
  EXPECT_NEAR(v.x, 2.f * 1.0625f, 1e-4f);
  EXPECT_NEAR(v.y, 1.0625f, 1e-4f);
  EXPECT_EQ(v.z, 0.f);
}

}  // namespace
}  // namespace pbgi::sh
