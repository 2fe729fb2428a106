// Point sets on the unit square and their maps to triangles and disks,
// shared by light sampling, surfel placement and pixel sampling.
#pragma once

#include "server/scene/rng.h"

#include <Imath/ImathVec.h>

#include <cmath>
#include <cstdint>

namespace pbgi {

inline constexpr float kPi = 3.14159265358979323846f;
inline constexpr float kInvPi = 0.31830988618379067154f;

// Sample i of n stratified jittered samples on [0,1)^2. The n samples use
// the largest rows x cols grid with rows*cols <= n (rows = floor(sqrt(n)));
// samples beyond the grid are plain uniform. Every sample is unbiased for
// the mean over the square, so their average is too, for any n.
inline Imath::V2f stratified_sample(uint32_t i, uint32_t n, Rng& rng) {
  const uint32_t rows = static_cast<uint32_t>(std::sqrt(static_cast<double>(n)));
  const uint32_t cols = rows ? n / rows : 0;
  const float u1 = rng.uniform(), u2 = rng.uniform();
  if (i >= rows * cols) return {u1, u2};
  const uint32_t r = i / cols, c = i % cols;
  // min() keeps the sample inside [0,1) when float rounding would reach 1.
  return {std::fmin((static_cast<float>(c) + u1) / static_cast<float>(cols), 0x1.fffffep-1f),
          std::fmin((static_cast<float>(r) + u2) / static_cast<float>(rows), 0x1.fffffep-1f)};
}

// The R2 low-discrepancy sequence (Roberts 2018): a Kronecker sequence with
// the plastic number's inverse powers, the 2D rank-1 lattice with the best
// known packing for an open-ended number of points. `offset` is a random
// shift (Cranley-Patterson rotation) that keeps the set uniform in
// expectation while preserving its spacing.
inline Imath::V2f r2_sample(uint32_t i, const Imath::V2f& offset) {
  constexpr double kA1 = 0.75487766624669276005;  // 1/g, g = plastic number
  constexpr double kA2 = 0.56984029099805326591;  // 1/g^2
  double x = offset.x + kA1 * (static_cast<double>(i) + 1.0);
  double y = offset.y + kA2 * (static_cast<double>(i) + 1.0);
  x -= std::floor(x);
  y -= std::floor(y);
  return {static_cast<float>(x), static_cast<float>(y)};
}

// Barycentrics (b1, b2) of a uniform point in a triangle from u in [0,1)^2,
// with Heitz's low-distortion square-to-triangle map (2019, "A Low-Distortion
// Map Between Triangle and Square"): unlike the sqrt map it keeps the
// spacing of a stratified or low-discrepancy point set.
inline Imath::V2f square_to_triangle(const Imath::V2f& u) {
  float b0, b1;
  if (u.x < u.y) {
    b0 = u.x * 0.5f;
    b1 = u.y - b0;
  } else {
    b1 = u.y * 0.5f;
    b0 = u.x - b1;
  }
  // (b0, b1) weight vertices 0 and 1 in Heitz's paper; we return the weights
  // of vertices 1 and 2 as Embree's (u, v) do. Any vertex order is uniform.
  return {b1, 1.f - b0 - b1};
}

// Uniform point on the unit disk, Shirley-Chiu concentric map (keeps
// stratification).
inline Imath::V2f square_to_disk(const Imath::V2f& u) {
  const float a = 2.f * u.x - 1.f, b = 2.f * u.y - 1.f;
  if (a == 0.f && b == 0.f) return {0.f, 0.f};
  float r, phi;
  if (std::fabs(a) > std::fabs(b)) {
    r = a;
    phi = (kPi / 4.f) * (b / a);
  } else {
    r = b;
    phi = (kPi / 2.f) - (kPi / 4.f) * (a / b);
  }
  return {r * std::cos(phi), r * std::sin(phi)};
}

// Any orthonormal (t, b) completing unit n to a right-handed frame
// (Duff et al. 2017, "Building an Orthonormal Basis, Revisited").
inline void orthonormal_basis(const Imath::V3f& n, Imath::V3f* t, Imath::V3f* b) {
  const float sign = std::copysign(1.f, n.z);
  const float a = -1.f / (sign + n.z);
  const float c = n.x * n.y * a;
  *t = Imath::V3f(1.f + sign * n.x * n.x * a, sign * c, -sign * n.x);
  *b = Imath::V3f(c, sign + n.y * n.y * a, -n.y);
}

}  // namespace pbgi
