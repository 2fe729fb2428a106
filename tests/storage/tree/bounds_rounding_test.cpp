// Rounded node bounds (V8/V9 page sets, storage/tree/bounds_rounding.h):
// the rounded cone contains the cone it rounds and is at most the stated
// amount wider (FORMAT.md), and a link record's code holds it exactly.
#include "storage/tree/bounds_rounding.h"

#include "storage/format/packed_values.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

namespace pbgi::tree {
namespace {

Imath::V3d random_unit(std::mt19937& rng) {
  std::normal_distribution<double> g;
  Imath::V3d v(g(rng), g(rng), g(rng));
  return v.normalized();
}

// A unit vector at `angle` from the unit vector `a`, towards `towards`.
Imath::V3d at_angle(const Imath::V3d& a, const Imath::V3d& towards, double angle) {
  Imath::V3d p = towards - a * a.dot(towards);
  p = p.length() > 1e-9 ? p.normalized()
                        : (std::abs(a.x) < 0.9 ? Imath::V3d(1, 0, 0) : Imath::V3d(0, 1, 0)).cross(a).normalized();
  return a * std::cos(angle) + p * std::sin(angle);
}

TEST(BoundsRounding, ConeContainsTheConeItRoundsWithinItsBound) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0, 1);
  double worst_widening = 0;
  for (int i = 0; i < 200000; ++i) {
    const Imath::V3d axis = random_unit(rng);
    // Half angles from 0 (one normal) to pi (every direction).
    const double theta = i % 10 == 0 ? 0.0 : i % 10 == 1 ? M_PI : M_PI * std::pow(u(rng), 3.0);
    const NormalCone c{Imath::V3f(axis), float(std::cos(theta))};
    const NormalCone r = round_cone_outward(c);
    const double theta_in = std::acos(std::clamp(double(c.cos_half_angle), -1.0, 1.0));
    const double theta_out = std::acos(std::clamp(double(r.cos_half_angle), -1.0, 1.0));
    // Containment, at the rim of the input cone in a few directions (a
    // wide cone holds every direction; the float axis is unit to ~6e-8).
    for (int k = 0; k < 4 && !r.is_wide(); ++k) {
      const Imath::V3d n = at_angle(Imath::V3d(c.axis).normalized(), random_unit(rng), theta_in);
      ASSERT_GE(Imath::V3d(r.axis).normalized().dot(n), double(r.cos_half_angle)) << i;
    }
    // Widening: the axis's move (<= storage::kOctahedralMaxAngle) plus the half
    // float's step on 1 - cos (2^-11 relative, 6e-8 absolute at least).
    // (From the chord: acos of a dot product near 1 is too coarse here.)
    const double moved =
        2 * std::asin((Imath::V3d(c.axis).normalized() - Imath::V3d(r.axis).normalized()).length() / 2);
    ASSERT_LE(moved, storage::kOctahedralMaxAngle) << i;
    const double bound_cos = std::cos(std::min(M_PI, theta_in + 1.0002 * storage::kOctahedralMaxAngle + 1e-7));
    ASSERT_LE(1.0 - double(r.cos_half_angle), (1.0 - bound_cos) * (1 + 0x1p-10) + 1.2e-7) << i;
    if (theta_in < 3.0) worst_widening = std::max(worst_widening, theta_out - theta_in);
    // The code holds it exactly.
    uint32_t axis_code = 0;
    uint16_t s = 0;
    ASSERT_TRUE(cone_code(r, axis_code, s)) << i;
    NormalCone back;
    ASSERT_TRUE(cone_of_code(axis_code, s, back));
    ASSERT_EQ(back.axis, r.axis) << i;
    ASSERT_EQ(back.cos_half_angle, r.cos_half_angle) << i;
  }
  std::printf("rounded cones: half angle grows by at most %.3g rad (below 3 rad)\n", worst_widening);
  // A wide cone stays wide.
  EXPECT_TRUE(round_cone_outward({{0, 0, 1}, -1.f}).is_wide());
}

// Axes the build meets (decoded 12-bit surfel normals, decoded 16-bit
// axes, axis-aligned ones) all have a code. Failed before stable_axis():
// on the lower hemisphere, an axis decoded with x or y = 0 re-encodes to
// the mirrored code, which decodes a few ulp away.
TEST(BoundsRounding, EveryRoundedConeHasACode) {
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  for (int i = 0; i < 2000000; ++i) {
    Imath::V3f a = i % 3 == 0   ? storage::decode_octahedral_bits(uint32_t(rng()) & 0xffffffu, 12)
                   : i % 3 == 1 ? storage::decode_octahedral_bits(uint32_t(rng()), 16)
                                : Imath::V3f(u(rng), u(rng), u(rng)).normalized();
    if (i % 7 == 0) a[int(rng() % 2)] = 0.f, a.normalize();  // on the fold's axes
    const NormalCone r = round_cone_outward({a, i % 5 == 0 ? 1.f : u(rng)});
    uint32_t axis_code = 0;
    uint16_t s = 0;
    ASSERT_TRUE(cone_code(r, axis_code, s)) << i << ": " << a.x << " " << a.y << " " << a.z;
  }
  // One the build met (a city's wall cone), and axis-aligned axes.
  for (const Imath::V3f& a : {Imath::V3f(-1.18200023e-05f, -0.999639213f, -0.0268580001f), Imath::V3f(0, 0, -1),
                              Imath::V3f(0, -1, 0), Imath::V3f(-1, 0, 0), Imath::V3f(0, 0, 1)}) {
    uint32_t axis_code = 0;
    uint16_t s = 0;
    EXPECT_TRUE(cone_code(round_cone_outward({a, 1.f}), axis_code, s)) << a.x << " " << a.y << " " << a.z;
  }
}

TEST(BoundsRounding, CodesNoWriterProducesAreRefused) {
  NormalCone out;
  for (const uint16_t bad : {uint16_t(0x7e00) /*NaN*/, uint16_t(0x7c00) /*inf*/, uint16_t(0x8001) /*negative*/,
                             uint16_t(0x4001) /*past 2*/}) {
    EXPECT_FALSE(cone_of_code(0, bad, out)) << bad;
  }
  EXPECT_TRUE(cone_of_code(0, 0x4000 /*2: every direction*/, out));
  EXPECT_TRUE(out.is_wide());
  // A cone that was not rounded has no code.
  uint32_t axis_code = 0;
  uint16_t s = 0;
  EXPECT_FALSE(cone_code({Imath::V3f(1, 2, 3).normalized(), 0.3f}, axis_code, s));
}

}  // namespace
}  // namespace pbgi::tree
