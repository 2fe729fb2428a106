// The surfel section of V8-V11 pages (storage/pages/surfel_section.h):
// compact records round-trip bit for bit, similar records take few bits,
// V10's radius prediction and positions on coarse grids, bytes no writer
// produces are refused.
#include "storage/pages/surfel_section.h"

#include "common/errors.h"
#include "storage/format/byte_order.h"
#include "storage/format/format_version.h"
#include "storage/tree/leaf_format.h"

#include <gtest/gtest.h>

#include <cmath>
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

// Puts every record's position codes on the grid of 2^shift codes
// (8191 + 2^shift j, as page_records.h writes them), keeping their high
// bits.
void put_on_grid(std::vector<uint8_t>& records, int shift = 4) {
  const uint64_t ones = (uint64_t(1) << shift) - 1;
  for (size_t at = 0; at < records.size(); at += kCompactSurfelRecordBytes) {
    auto g = load_le<uint64_t>(records.data() + at);
    for (int axis = 0; axis < 3; ++axis) g |= ones << (14 * axis);
    store_le<uint64_t>(records.data() + at, g);
  }
}

// Leaves of 1-4 surfels holding n records, of a few frame radii (0: a leaf
// of zero-size surfels).
std::vector<LeafRecord> random_leaves(size_t n, std::mt19937& rng) {
  const float radii[] = {0.f, 0.25f, 0.5f, 1.f, 1.375f, 3.f};
  std::vector<LeafRecord> leaves;
  while (n > 0) {
    LeafRecord l;
    l.surfel_count = uint32_t(std::min<size_t>(n, 1 + rng() % 4));
    l.frame.radius = radii[rng() % std::size(radii)];
    n -= l.surfel_count;
    leaves.push_back(l);
  }
  return leaves;
}

TEST(SurfelSection, RoundTripsBitForBit) {
  std::mt19937 rng(2);
  for (const uint32_t format : {kPageFormatV8, kPageFormatV10}) {
    for (int k = 0; k < 3000; ++k) {
      const size_t n = 1 + rng() % 40;
      auto records = random_records(n, rng, k % 3 == 0 ? 0xff : k % 3 == 1 ? 0x03 : 0x00);
      if (format == kPageFormatV10) put_on_grid(records);
      const std::vector<LeafRecord> leaves = random_leaves(n, rng);
      std::vector<uint8_t> bytes;
      encode_surfel_section(records, leaves, format, bytes);
      if (k % 3 == 2 && format == kPageFormatV8) {
        EXPECT_LE(bytes.size(), 26u) << "identical records: the column header alone";
      }
      bytes.push_back(0xee);  // what follows is not read
      std::vector<uint8_t> back;
      ASSERT_EQ(decode_surfel_section(bytes, leaves, format, back, "p"), bytes.size() - 1) << format << " " << k;
      ASSERT_EQ(back, records) << format << " " << k;
    }
    std::vector<uint8_t> none, back;
    encode_surfel_section({}, {}, format, none);
    EXPECT_TRUE(none.empty());
    EXPECT_EQ(decode_surfel_section({}, {}, format, back, "p"), 0u);
  }
}

// Surfels of one radius in the world, in leaves of different frame radii:
// V8 stores each radius code (r / R of its leaf) in the bits the page's
// spread of codes needs, V10 the differences to the rescaled previous
// code, which are within rounding.
TEST(SurfelSection, RadiiOfOneWorldSizeCostFewBitsInV10) {
  std::mt19937 rng(5);
  const size_t n = 24;
  auto records = random_records(n, rng, 0x00);
  put_on_grid(records);
  std::vector<LeafRecord> leaves;
  const float r = 0.1f;
  for (size_t i = 0; i < n; i += 3) {
    LeafRecord l;
    l.surfel_count = 3;
    l.frame.radius = 0.12f + 0.05f * float(i);  // 0.12 .. 1.17
    leaves.push_back(l);
    for (size_t k = i; k < i + 3; ++k) {
      const auto code = uint32_t(std::lround(double(r) / double(l.frame.radius) * 8191.0));
      uint8_t* rec = records.data() + k * kCompactSurfelRecordBytes;
      const auto hi = load_le<uint16_t>(rec + 8);
      store_le<uint16_t>(rec + 8, uint16_t((hi & ~(0x1fffu << 2)) | code << 2));  // radius: bits 66-78
    }
  }
  std::vector<uint8_t> v8, v10, back;
  encode_surfel_section(records, leaves, kPageFormatV8, v8);
  encode_surfel_section(records, leaves, kPageFormatV10, v10);
  // V8: 13 bits a surfel for the radius (codes 700 .. 6826); V10: at most
  // 2 (differences of -1 .. 1) plus 13 for the first code.
  EXPECT_LE(v10.size() * 8 + (13 - 2) * (n - 1) - 13, v8.size() * 8) << v8.size() << " " << v10.size();
  ASSERT_EQ(decode_surfel_section(v10, leaves, kPageFormatV10, back, "p"), v10.size());
  EXPECT_EQ(back, records);
}

// Positions on a grid of 2^s codes take s bits fewer a coordinate in V10;
// the page's coarsest common grid is found whatever the records.
TEST(SurfelSection, PositionsOnACoarseGridTakeFewerBitsInV10) {
  std::mt19937 rng(7);
  const size_t n = 16;
  const auto records = random_records(n, rng, 0xff);
  const auto leaves = random_leaves(n, rng);
  std::vector<size_t> sizes;
  for (const int shift : {0, 2, 4}) {
    auto grid = records;
    put_on_grid(grid, shift);
    std::vector<uint8_t> bytes, back;
    encode_surfel_section(grid, leaves, kPageFormatV10, bytes);
    ASSERT_EQ(decode_surfel_section(bytes, leaves, kPageFormatV10, back, "p"), bytes.size());
    EXPECT_EQ(back, grid) << shift;
    sizes.push_back(bytes.size());
  }
  // 3 coordinates x (16 values + the smallest) x 2 bits fewer from one
  // grid to the next, give or take the radius column's few bits.
  EXPECT_LT(sizes[1], sizes[0]);
  EXPECT_LT(sizes[2], sizes[1]);
  EXPECT_GE(sizes[0] - sizes[2], 3 * 17 * 4 / 8 - 8);
}

TEST(SurfelSection, WhatNoWriterProducesIsRefused) {
  std::mt19937 rng(3);
  const auto records = random_records(6, rng, 0x0f);
  const std::vector<LeafRecord> six = {{{}, 6}};
  std::vector<uint8_t> good;
  encode_surfel_section(records, six, kPageFormatV8, good);
  auto expect_corrupt = [&](const std::vector<uint8_t>& bad, uint32_t format, const std::vector<LeafRecord>& leaves,
                            const std::string& what) {
    std::vector<uint8_t> out;
    try {
      decode_surfel_section(bad, leaves, format, out, "/x/pages.pbgp: page 4");
      FAIL() << what << ": accepted";
    } catch (const CorruptionError& e) {
      EXPECT_TRUE(contains(e.what(), "/x/pages.pbgp: page 4: surfel section")) << e.what();
    }
  };
  expect_corrupt({good.begin(), good.end() - 1}, kPageFormatV8, six, "a byte short");
  expect_corrupt({good.begin(), good.begin() + 10}, kPageFormatV8, six, "the column header cut");
  // The first column (x, 14 bits): its smallest value 16383 and a width
  // of 1 put a value past the field.
  auto bad = good;
  bad[0] = 0xff, bad[1] = 0x3f;                                      // min 16383
  bad[1] = uint8_t(bad[1] | 0x40), bad[2] = uint8_t(bad[2] & 0xfc);  // width 1
  expect_corrupt(bad, kPageFormatV8, six, "a value past its field");
  bad = good;
  bad[1] |= 0xc0, bad[2] |= 0x03;  // width 15 > 14
  expect_corrupt(bad, kPageFormatV8, six, "a width past its field");

  // V10: a position shift of 5 (bits 0-2: at most 4).
  auto on_grid = records;
  put_on_grid(on_grid);
  std::vector<LeafRecord> leaves = {{{{0, 0, 0}, 1.f}, 3}, {{{0, 0, 0}, 2.f}, 3}};
  std::vector<uint8_t> v10;
  encode_surfel_section(on_grid, leaves, kPageFormatV10, v10);
  ASSERT_EQ(v10[0] & 7, 4) << "positions on the grid of 16 codes";
  bad = v10;
  bad[0] = uint8_t((bad[0] & ~7u) | 5u);
  expect_corrupt(bad, kPageFormatV10, leaves, "a shift past 4");
  // The radius column's smallest difference (14 bits after the first
  // code's 13, which follow the shift's 3 bits, x, y, z's 3 x (10 + 4)
  // and the normal's 2 x 16 header bits: bits 90-103) set to its largest,
  // 16383: a code of 8192 or more, past the field.
  bad = v10;
  for (int b = 90; b <= 103; ++b) bad[size_t(b / 8)] = uint8_t(bad[size_t(b / 8)] | 1u << (b % 8));
  expect_corrupt(bad, kPageFormatV10, leaves, "a radius past its field");
}

}  // namespace
}  // namespace pbgi::storage
