// The surfel section of V8/V9 pages (storage/pages/surfel_section.h):
// compact records round-trip bit for bit, similar records take few bits,
// bytes no writer produces are refused.
#include "storage/pages/surfel_section.h"

#include "common/errors.h"
#include "storage/tree/leaf_format.h"

#include <gtest/gtest.h>

#include <random>
#include <string>
#include <vector>

namespace pbgi::storage {
namespace {

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

std::vector<uint8_t> random_records(size_t n, std::mt19937& rng, uint8_t spread) {
  // Records alike but for their low bits (`spread`: 0 = identical, 255 = random).
  std::vector<uint8_t> base(kCompactSurfelRecordBytes);
  for (uint8_t& b : base) b = uint8_t(rng());
  std::vector<uint8_t> out;
  for (size_t i = 0; i < n; ++i) {
    for (uint8_t b : base) out.push_back(uint8_t(b ^ (uint8_t(rng()) & spread)));
  }
  return out;
}

TEST(SurfelSection, RoundTripsBitForBit) {
  std::mt19937 rng(2);
  for (int k = 0; k < 3000; ++k) {
    const size_t n = 1 + rng() % 40;
    const auto records = random_records(n, rng, k % 3 == 0 ? 0xff : k % 3 == 1 ? 0x03 : 0x00);
    std::vector<uint8_t> bytes;
    encode_surfel_section(records, bytes);
    if (k % 3 == 2) {
      EXPECT_LE(bytes.size(), 26u) << "identical records: the column header alone";
    }
    bytes.push_back(0xee);  // what follows is not read
    std::vector<uint8_t> back;
    ASSERT_EQ(decode_surfel_section(bytes, n, back, "p"), bytes.size() - 1) << k;
    ASSERT_EQ(back, records) << k;
  }
  std::vector<uint8_t> none, back;
  encode_surfel_section({}, none);
  EXPECT_TRUE(none.empty());
  EXPECT_EQ(decode_surfel_section({}, 0, back, "p"), 0u);
}

TEST(SurfelSection, WhatNoWriterProducesIsRefused) {
  std::mt19937 rng(3);
  const auto records = random_records(6, rng, 0x0f);
  std::vector<uint8_t> good;
  encode_surfel_section(records, good);
  auto expect_corrupt = [&](const std::vector<uint8_t>& bad, const std::string& what) {
    std::vector<uint8_t> out;
    try {
      decode_surfel_section(bad, 6, out, "/x/pages.pbgp: page 4");
      FAIL() << what << ": accepted";
    } catch (const CorruptionError& e) {
      EXPECT_TRUE(contains(e.what(), "/x/pages.pbgp: page 4: surfel section")) << e.what();
    }
  };
  expect_corrupt({good.begin(), good.end() - 1}, "a byte short");
  expect_corrupt({good.begin(), good.begin() + 10}, "the column header cut");
  // The first column (x, 14 bits): its smallest value 16383 and a width
  // of 1 put a value past the field.
  auto bad = good;
  bad[0] = 0xff, bad[1] = 0x3f;                                      // min 16383
  bad[1] = uint8_t(bad[1] | 0x40), bad[2] = uint8_t(bad[2] & 0xfc);  // width 1
  expect_corrupt(bad, "a value past its field");
  bad = good;
  bad[1] |= 0xc0, bad[2] |= 0x03;  // width 15 > 14
  expect_corrupt(bad, "a width past its field");
}

}  // namespace
}  // namespace pbgi::storage
