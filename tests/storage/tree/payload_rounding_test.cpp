// The rounded payloads of V6/V7 trees: within their stated precision,
// idempotent, and stored in 76 bytes exactly.
#include "storage/tree/payload_rounding.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace pbgi::tree {
namespace {

float* block(Node& n, int b) {
  return b == 0   ? n.radiance_sh.r.data()
         : b == 1 ? n.radiance_sh.g.data()
         : b == 2 ? n.radiance_sh.b.data()
                  : n.coverage_sh.data();
}

// Blocks of random magnitudes (1e-30 to 1e30), signs, and spreads within a
// block (up to 1e6 between coefficients).
Node random_payload(std::mt19937& rng) {
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  Node n;
  for (int b = 0; b < 4; ++b) {
    const float scale = std::pow(10.f, 30.f * u(rng));
    for (int i = 0; i < 9; ++i) block(n, b)[i] = scale * u(rng) * std::pow(10.f, -3.f * (u(rng) + 1.f));
  }
  return n;
}

TEST(PayloadRounding, WithinItsStatedPrecisionIdempotentAndStoredExactly) {
  std::mt19937 rng(19);
  for (int k = 0; k < 100000; ++k) {
    const Node exact = random_payload(rng);
    Node r = exact;
    round_payload(r);
    for (int b = 0; b < 4; ++b) {
      Node e = exact;
      float m = 0.f;
      for (int i = 0; i < 9; ++i) m = std::max(m, std::abs(block(e, b)[i]));
      for (int i = 0; i < 9; ++i) {
        // 2^-15 of the block's largest magnitude; a block below 2^-100 is zero.
        const float tol = m < 0x1p-100f ? m : m * 0x1p-15f;
        ASSERT_LE(std::abs(block(r, b)[i] - block(e, b)[i]), tol) << k << " " << b << " " << i;
        if (m < 0x1p-100f) {
          ASSERT_EQ(block(r, b)[i], 0.f);
        }
      }
    }
    Node again = r;
    round_payload(again);
    ASSERT_EQ(again.radiance_sh.r, r.radiance_sh.r);
    ASSERT_EQ(again.coverage_sh, r.coverage_sh);
    uint8_t bytes[kRoundedPayloadBytes];
    write_rounded_payload(r, bytes);
    Node back;
    ASSERT_TRUE(read_rounded_payload(bytes, back));
    ASSERT_EQ(back.radiance_sh.r, r.radiance_sh.r);
    ASSERT_EQ(back.radiance_sh.g, r.radiance_sh.g);
    ASSERT_EQ(back.radiance_sh.b, r.radiance_sh.b);
    ASSERT_EQ(back.coverage_sh, r.coverage_sh);
  }
}

TEST(PayloadRounding, ZeroAndTinyBlocksAreZeroAndBadExponentsRefused) {
  Node n;
  n.coverage_sh[3] = 1e-31f;
  n.radiance_sh.r[0] = 2.f;
  round_payload(n);
  EXPECT_EQ(n.coverage_sh[3], 0.f);
  EXPECT_EQ(n.radiance_sh.r[0], 2.f);  // a power of two is exact
  EXPECT_EQ(n.radiance_sh.g[0], 0.f);
  uint8_t bytes[kRoundedPayloadBytes];
  write_rounded_payload(n, bytes);
  Node back;
  ASSERT_TRUE(read_rounded_payload(bytes, back));
  EXPECT_EQ(back.radiance_sh.r, n.radiance_sh.r);
  bytes[0] = 255;  // exponent 127: past any float
  EXPECT_FALSE(read_rounded_payload(bytes, back));
  bytes[0] = 0;  // exponent -128: below the smallest the writer uses
  EXPECT_FALSE(read_rounded_payload(bytes, back));
}

}  // namespace
}  // namespace pbgi::tree
