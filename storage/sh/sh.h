// Real spherical harmonics, 3 bands (9 coefficients), the basis of the
// node payloads. Conventions follow Sloan, "Stupid SH tricks" (2008):
// index i = l*(l+1)+m, directions are unit vectors in world space, same
// normalization (orthonormal over the sphere), but without the
// Condon-Shortley phase: the odd-m functions of band 1 and 2 have a + sign
// (y, x, yz, xz). Any consistent sign choice gives the same functions once
// projected and evaluated with this basis; coefficients are not
// interchangeable with Sloan's tables.
//
// Thread-safety: pure functions.
#pragma once

#include <Imath/ImathColor.h>
#include <Imath/ImathVec.h>

#include <array>

namespace pbgi::sh {

inline constexpr int kBands = 3;
inline constexpr int kCoeffs = kBands * kBands;   // 9
inline constexpr float kPi = 3.14159265358979323846f;

using Sh9 = std::array<float, kCoeffs>;

// One SH function per color channel: 27 floats, the paper's node data vector.
struct ShRgb {
  Sh9 r{}, g{}, b{};
};

// Evaluates the 9 basis functions at unit direction d.
inline Sh9 basis(const Imath::V3f& d) {
  const float x = d.x, y = d.y, z = d.z;
  return {0.282094792f,
          0.488602512f * y, 0.488602512f * z, 0.488602512f * x,
          1.092548431f * x * y, 1.092548431f * y * z,
          0.315391565f * (3.f * z * z - 1.f),
          1.092548431f * x * z, 0.546274215f * (x * x - y * y)};
}

inline float dot(const Sh9& a, const Sh9& b) {
  float s = 0.f;
  for (int i = 0; i < kCoeffs; ++i) s += a[i] * b[i];
  return s;
}

// SH of the clamped cosine lobe max(0, n.w) around unit axis n: the zonal
// coefficients pi, 2pi/3, pi/4 (Ramamoorthi & Hanrahan 2001) rotated to n.
inline Sh9 clamped_cosine(const Imath::V3f& n) {
  Sh9 y = basis(n);
  constexpr float a0 = kPi, a1 = 2.f * kPi / 3.f, a2 = kPi / 4.f;
  y[0] *= a0;
  for (int i = 1; i < 4; ++i) y[i] *= a1;
  for (int i = 4; i < 9; ++i) y[i] *= a2;
  return y;
}

inline void add_scaled(Sh9& acc, const Sh9& v, float s) {
  for (int i = 0; i < kCoeffs; ++i) acc[i] += s * v[i];
}

inline void add_scaled(ShRgb& acc, const Sh9& lobe, const Imath::C3f& c) {
  add_scaled(acc.r, lobe, c.x);
  add_scaled(acc.g, lobe, c.y);
  add_scaled(acc.b, lobe, c.z);
}

inline void add_scaled(ShRgb& acc, const ShRgb& v, float s) {
  add_scaled(acc.r, v.r, s);
  add_scaled(acc.g, v.g, s);
  add_scaled(acc.b, v.b, s);
}

inline Imath::C3f evaluate(const ShRgb& f, const Sh9& basis_at_d) {
  return {dot(f.r, basis_at_d), dot(f.g, basis_at_d), dot(f.b, basis_at_d)};
}

// Energy of band l (sum of squares of its 2l+1 coefficients); invariant
// under rotation of the function.
inline float band_energy(const Sh9& f, int l) {
  float s = 0.f;
  for (int m = -l; m <= l; ++m) s += f[l * (l + 1) + m] * f[l * (l + 1) + m];
  return s;
}

}  // namespace pbgi::sh
