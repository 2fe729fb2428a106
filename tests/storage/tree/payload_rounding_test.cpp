// The rounded payloads of V6/V7 trees: within their stated precision,
// idempotent, and stored in 76 bytes exactly.
#include "storage/tree/payload_rounding.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

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

// The compact form (V8/V9 links) holds a rounded payload exactly, in at
// most kMaxCompactPayloadBytes; zero blocks take one byte; bytes no writer produces are
// refused.
TEST(PayloadRounding, CompactFormHoldsRoundedPayloadsExactly) {
  std::mt19937 rng(23);
  size_t total = 0;
  for (int k = 0; k < 100000; ++k) {
    Node r = random_payload(rng);
    if (k % 3 == 0) std::fill(block(r, k % 4), block(r, k % 4) + 9, 0.f);            // a dark channel
    if (k % 5 == 0) block(r, 1)[4] = block(r, 1)[7] = 0.f, block(r, 1)[8] *= 1e-4f;  // small higher bands
    round_payload(r);
    std::vector<uint8_t> bytes;
    write_compact_payload(r, bytes);
    ASSERT_LE(bytes.size(), kMaxCompactPayloadBytes);
    total += bytes.size();
    bytes.push_back(0x55);  // what follows is not read
    Node back;
    ASSERT_EQ(read_compact_payload(bytes, back), bytes.size() - 1) << k;
    for (int b = 0; b < 4; ++b) {
      for (int i = 0; i < 9; ++i) ASSERT_EQ(block(back, b)[i], block(r, b)[i]) << k << " " << b << " " << i;
    }
  }
  std::printf("compact payloads: %.1f bytes each on random blocks\n", double(total) / 100000);
  Node zero;
  std::vector<uint8_t> z;
  write_compact_payload(zero, z);
  EXPECT_EQ(z, std::vector<uint8_t>(4, 0));

  Node one;
  one.coverage_sh[0] = 1.f;
  one.coverage_sh[3] = 0.25f;     // q = 8192: an i16
  one.coverage_sh[5] = 0x1p-13f;  // q = 2: an i8
  round_payload(one);
  std::vector<uint8_t> good;
  write_compact_payload(one, good);
  ASSERT_EQ(good.size(), 3u + 1 + 3 + 2 + 2 + 1);  // three zero blocks; exponent, classes, i16, i16, i8
  Node back;
  auto refused = [&](std::vector<uint8_t> bad) { return read_compact_payload(bad, back) == 0; };
  for (size_t cut = 1; cut < good.size(); ++cut) EXPECT_TRUE(refused({good.begin(), good.end() - long(cut)})) << cut;
  auto bad = good;
  bad[3] = 255;  // exponent 127
  EXPECT_TRUE(refused(bad));
  bad = good;
  bad[6] |= 0x04;  // a spare bit of the classes
  EXPECT_TRUE(refused(bad));
  bad = good;
  bad[4] |= 0x0c;  // coefficient 1: class 3
  EXPECT_TRUE(refused(bad));
  bad = good;
  bad[11] = 0;  // the i8 holds 0
  EXPECT_TRUE(refused(bad));
  bad = good;
  bad[7] = 5, bad[8] = 0;  // the first i16 fits an i8
  EXPECT_TRUE(refused(bad));
}

}  // namespace
}  // namespace pbgi::tree
