#include "storage/codecs/bit_packing.h"

#include <gtest/gtest.h>

#include <random>

namespace pbgi::storage {
namespace {

TEST(BitPacking, BitsForCount) {
  EXPECT_EQ(bits_for_count(0), 0u);
  EXPECT_EQ(bits_for_count(1), 0u);
  EXPECT_EQ(bits_for_count(2), 1u);
  EXPECT_EQ(bits_for_count(100), 7u);
  EXPECT_EQ(bits_for_count(128), 7u);
  EXPECT_EQ(bits_for_count(129), 8u);
  EXPECT_EQ(bits_for_count(1000), 10u);
  EXPECT_EQ(bits_for_count(10000), 14u);
  EXPECT_EQ(bits_for_count(65536), 16u);
}

// Every width used by LUT indices (7..16) and scale codes, alone and
// interleaved with a second width, with odd counts so the last byte is partial.
TEST(BitPacking, RoundTripEveryWidth) {
  std::mt19937 rng(3);
  for (uint32_t bits = 1; bits <= 24; ++bits) {
    for (size_t count : {1u, 7u, 1001u}) {
      std::vector<uint32_t> codes(count);
      for (auto& c : codes) c = rng() & ((1u << bits) - 1);
      codes[0] = (1u << bits) - 1;  // all ones
      std::vector<uint8_t> bytes{0x5A};  // appends after existing bytes
      BitWriter w(bytes);
      for (uint32_t c : codes) w.put(c, bits);
      w.finish();
      ASSERT_EQ(bytes.size(), 1 + packed_bytes(count, bits)) << bits;
      EXPECT_EQ(bytes[0], 0x5A);
      BitReader r{std::span<const uint8_t>(bytes).subspan(1)};
      for (size_t i = 0; i < count; ++i) ASSERT_EQ(r.get(bits), codes[i]) << "bits " << bits << " code " << i;
    }
  }
}

TEST(BitPacking, InterleavedWidthsAndLayout) {
  for (uint32_t index_bits = 7; index_bits <= 16; ++index_bits) {
    std::vector<uint8_t> bytes;
    BitWriter w(bytes);
    for (uint32_t i = 0; i < 333; ++i) {
      w.put(i * 7919u % (1u << index_bits), index_bits);
      w.put(i % 4096u, 12);
    }
    w.finish();
    ASSERT_EQ(bytes.size(), packed_bytes(333, index_bits + 12));
    BitReader r(bytes);
    for (uint32_t i = 0; i < 333; ++i) {
      ASSERT_EQ(r.get(index_bits), i * 7919u % (1u << index_bits));
      ASSERT_EQ(r.get(12), i % 4096u);
    }
  }
  // LSB-first: codes 1 (3 bits) and 5 (5 bits) -> byte 0b00101001.
  std::vector<uint8_t> b;
  BitWriter w(b);
  w.put(1, 3);
  w.put(5, 5);
  w.finish();
  ASSERT_EQ(b.size(), 1u);
  EXPECT_EQ(b[0], 0x29);
}

}  // namespace
}  // namespace pbgi::storage
