#include "server/gather/view_codes.h"

#include "storage/format/packed_values.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

namespace pbgi::gather {
namespace {

using Imath::C3f;

float max_channel(const C3f& c) { return std::max(c.x, std::max(c.y, c.z)); }

// Each channel within max(r, g, b) / 16384 of its input, over colours
// spanning the code's range, dark channels beside bright ones included.
TEST(Rgb48, ChannelsAreWithinTheBrightestOneOver16384) {
  for (const float tiny : {1e-11f, 3e-14f}) {
    const C3f d = decode_rgb48(encode_rgb48(C3f(tiny, 0.f, tiny * 0.5f)));
    EXPECT_LE(std::abs(d.x - tiny), std::exp2(-47.f)) << tiny;
  }
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  std::uniform_real_distribution<float> exponent(-32.f, 29.f);
  for (int i = 0; i < 200000; ++i) {
    const float scale = std::exp2(exponent(rng));
    const C3f c(u(rng) * scale, u(rng) * u(rng) * scale, u(rng) * u(rng) * u(rng) * scale);
    const C3f d = decode_rgb48(encode_rgb48(c));
    // Below 2^-33 the step stays 2^-46: within half of it.
    const float tolerance = std::max(max_channel(c) / 16384.f, std::exp2(-47.f));
    for (int k = 0; k < 3; ++k) ASSERT_LE(std::abs(d[k] - c[k]), tolerance) << "colour " << i << " channel " << k;
  }
}

// The radiance of pages on disk is RGB9E5: re-encoded, it decodes to the
// same floats, so a leaf surfel read from disk keeps its radiance exactly.
TEST(Rgb48, Rgb9e5ValuesReencodeExactly) {
  std::mt19937 rng(11);
  std::uniform_int_distribution<uint32_t> code;
  for (int i = 0; i < 100000; ++i) {
    const C3f c = storage::decode_rgb9e5(code(rng));
    EXPECT_EQ(decode_rgb48(encode_rgb48(c)), c) << "code " << i;
  }
}

// Black, negative and NaN inputs: black stays black, negatives become 0,
// infinity the largest value, and a NaN channel makes every channel NaN
// (the gather counts and replaces non-finite results: the NaN must reach it).
TEST(Rgb48, EdgeValues) {
  EXPECT_EQ(decode_rgb48(encode_rgb48(C3f(0.f))), C3f(0.f));
  EXPECT_EQ(decode_rgb48(encode_rgb48(C3f(-1.f, 2.f, -0.f))), C3f(0.f, 2.f, 0.f));
  const C3f big = decode_rgb48(encode_rgb48(C3f(std::numeric_limits<float>::infinity(), 1.f, 0.f)));
  EXPECT_NEAR(big.x, 1e9f, 1e9f / 16384.f);
  EXPECT_TRUE(std::isfinite(big.x));
  const C3f nan = decode_rgb48(encode_rgb48(C3f(1.f, std::nanf(""), 0.f)));
  EXPECT_TRUE(std::isnan(nan.x) && std::isnan(nan.y) && std::isnan(nan.z));
}

// The codes' rounding: to nearest, ties up, exact below 2^23. The cast of
// t + 0.5f it replaced took the float just below 0.5 to 1 (the sum rounds
// to 1.0).
TEST(RoundHalfUp, NearestTiesUpExact) {
  EXPECT_EQ(round_half_up(0.f), 0u);
  EXPECT_EQ(round_half_up(std::nextafter(0.5f, 0.f)), 0u);
  EXPECT_EQ(round_half_up(0.5f), 1u);
  EXPECT_EQ(round_half_up(2.5f), 3u);
  EXPECT_EQ(round_half_up(std::nextafter(16383.5f, 0.f)), 16383u);
  EXPECT_EQ(round_half_up(16383.5f), 16384u);
  EXPECT_EQ(round_half_up(8388607.f), 8388607u);
}

}  // namespace
}  // namespace pbgi::gather
