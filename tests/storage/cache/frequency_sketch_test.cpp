// The page cache's frequency sketch: counts, saturation, aging by halving,
// resizing, and few overestimates among many keys.
#include "storage/cache/frequency_sketch.h"

#include <gtest/gtest.h>

namespace pbgi::storage {
namespace {

uint64_t key_hash(uint64_t k) { return k * 0x9E3779B97F4A7C15ull ^ (k >> 7); }

TEST(FrequencySketch, CountsUpToFifteen) {
  FrequencySketch s(64);
  EXPECT_EQ(s.estimate(key_hash(1)), 0u);
  for (uint32_t n = 1; n <= 20; ++n) {
    s.add(key_hash(1));
    EXPECT_EQ(s.estimate(key_hash(1)), std::min(n, 15u));
  }
  EXPECT_EQ(s.estimate(key_hash(2)), 0u);
}

TEST(FrequencySketch, HalvesEveryCountAfterItsSample) {
  FrequencySketch s(8);
  for (int n = 0; n < 12; ++n) s.add(key_hash(7));
  ASSERT_EQ(s.estimate(key_hash(7)), 12u);
  // Other keys until the sample is reached: key 7's count is halved.
  uint64_t k = 1000;
  for (; k < 1000 + 2 * s.sample_size() && s.estimate(key_hash(7)) == 12u; ++k) s.add(key_hash(k));
  EXPECT_EQ(s.estimate(key_hash(7)), 6u);
  EXPECT_LE(k - 1000, s.sample_size());
}

TEST(FrequencySketch, ResizeForgets) {
  FrequencySketch s(8);
  s.add(key_hash(3));
  EXPECT_EQ(s.items(), 8u);
  s.resize(1000);
  EXPECT_EQ(s.items(), 1000u);
  EXPECT_EQ(s.estimate(key_hash(3)), 0u);
  // 8 counters of 4 bits per item, rounded up to a power of two.
  EXPECT_EQ(s.bytes(), 8192u / 2);
}

TEST(FrequencySketch, FewOverestimatesAtItsSize) {
  // As many keys as it is sized for, each added once (no halving yet):
  // most estimates are exact, none is below the truth.
  constexpr uint64_t kItems = 1024;
  FrequencySketch s(kItems);
  for (uint64_t k = 0; k < kItems; ++k) s.add(key_hash(k));
  uint64_t exact = 0;
  for (uint64_t k = 0; k < kItems; ++k) {
    const uint32_t e = s.estimate(key_hash(k));
    EXPECT_GE(e, 1u);
    exact += e == 1 ? 1 : 0;
  }
  EXPECT_GE(exact, kItems * 95 / 100);
}

}  // namespace
}  // namespace pbgi::storage
