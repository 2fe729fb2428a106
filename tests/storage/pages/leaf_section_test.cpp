// The leaf section of V8/V9 pages (storage/pages/leaf_section.h): rounded
// frames and counts round-trip exactly, in delta or absolute form; bytes
// no writer produces are refused.
#include "storage/pages/leaf_section.h"

#include "common/errors.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

namespace pbgi::storage {
namespace {

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

// `n` neighbouring leaves (as a page's, in Morton order) of radii around `radius`.
std::vector<LeafRecord> neighbours(size_t n, float radius, const Imath::V3f& at, std::mt19937& rng) {
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  std::vector<LeafRecord> out(n);
  for (size_t i = 0; i < n; ++i) {
    const float r = radius * std::pow(2.f, 2.f * u(rng));
    const Imath::V3f c = at + 8.f * radius * Imath::V3f(u(rng), u(rng), u(rng));
    out[i].frame = round_frame_outward({c, r}).frame();
    out[i].surfel_count = 1 + uint32_t(rng() % 4);
  }
  return out;
}

void expect_round_trip(const std::vector<LeafRecord>& leaves) {
  std::vector<uint8_t> bytes;
  encode_leaf_section(leaves, bytes);
  bytes.push_back(0xab);  // what follows the section is not read
  std::vector<LeafRecord> back;
  ASSERT_EQ(decode_leaf_section(bytes, leaves.size(), back, "p"), bytes.size() - 1);
  ASSERT_EQ(back.size(), leaves.size());
  for (size_t i = 0; i < leaves.size(); ++i) {
    ASSERT_EQ(back[i].frame.center, leaves[i].frame.center) << i;
    ASSERT_EQ(back[i].frame.radius, leaves[i].frame.radius) << i;
    ASSERT_EQ(back[i].surfel_count, leaves[i].surfel_count) << i;
  }
}

TEST(LeafSection, RoundTripsExactly) {
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  size_t bytes = 0, leaves = 0;
  for (int page = 0; page < 2000; ++page) {
    const float scale = std::pow(10.f, 4.f * u(rng));
    const auto l =
        neighbours(1 + rng() % 8, std::pow(10.f, 3.f * u(rng)), scale * Imath::V3f(u(rng), u(rng), u(rng)), rng);
    expect_round_trip(l);
    std::vector<uint8_t> out;
    encode_leaf_section(l, out);
    bytes += out.size();
    leaves += l.size();
  }
  // Neighbours cost well below 13 bytes (three i24 centres, an exponent
  // and a radius) a leaf.
  EXPECT_LT(double(bytes) / double(leaves), 10.0);
  // No leaves, no bytes.
  std::vector<uint8_t> none;
  encode_leaf_section({}, none);
  EXPECT_TRUE(none.empty());
  std::vector<LeafRecord> back;
  EXPECT_EQ(decode_leaf_section({}, 0, back, "p"), 0u);
}

// Leaves whose centres lie too far apart on the finer one's grid: the
// section stores every centre in full (flag bit 4 of byte 0).
TEST(LeafSection, FarApartLeavesAreStoredInFull) {
  std::vector<LeafRecord> l(3);
  l[0] = {round_frame_outward({{1e6f, 0.f, -3e4f}, 1e3f}).frame(), 4};
  l[1] = {round_frame_outward({{-2e4f, 5.f, 0.25f}, 1e-3f}).frame(), 1};
  l[2] = {round_frame_outward({{0.f, 0.f, 0.f}, 0.f}).frame(), 4096};
  std::vector<uint8_t> bytes;
  encode_leaf_section(l, bytes);
  EXPECT_NE(bytes[0] & 0x10, 0) << "absolute centres";
  expect_round_trip(l);
}

TEST(LeafSection, WhatNoWriterProducesIsRefused) {
  std::mt19937 rng(4);
  const auto leaves = neighbours(5, 0.1f, {3.f, -2.f, 7.f}, rng);
  std::vector<uint8_t> good;
  encode_leaf_section(leaves, good);
  auto expect_corrupt = [&](std::vector<uint8_t> bad, size_t count, const std::string& what) {
    std::vector<LeafRecord> out;
    try {
      decode_leaf_section(bad, count, out, "/x/pages.pbgp: page 9");
      FAIL() << what << ": accepted";
    } catch (const CorruptionError& e) {
      EXPECT_TRUE(contains(e.what(), "/x/pages.pbgp: page 9: leaf section")) << e.what();
    }
  };
  for (const auto& [at, value] : std::vector<std::pair<size_t, uint8_t>>{
           {0, 0x20} /*reserved bit*/, {1, 26} /*delta bits*/, {2, 0x0d} /*radius bits*/, {2, 0xd0} /*count bits*/}) {
    auto bad = good;
    bad[at] = value;
    expect_corrupt(bad, 5, "width byte " + std::to_string(at));
  }
  expect_corrupt(std::vector<uint8_t>(good.begin(), good.end() - 1), 5, "a byte short");
  expect_corrupt({good.begin(), good.begin() + 2}, 5, "widths cut");
  // The first leaf's exponent byte: 0 (e = -128) and 255 (e = 127) are out of range.
  for (const uint8_t e : {uint8_t(0), uint8_t(255)}) {
    auto bad = good;
    bad[3] = e;
    expect_corrupt(bad, 5, "exponent " + std::to_string(e));
  }
  // Writers' bugs: a frame that is not rounded, a count out of range.
  std::vector<uint8_t> out;
  EXPECT_THROW(encode_leaf_section(std::vector<LeafRecord>{{{{0.1f, 0.f, 0.f}, 1.f}, 1}}, out), Error);
  auto zero = leaves;
  zero[2].surfel_count = 0;
  EXPECT_THROW(encode_leaf_section(zero, out), Error);
  zero[2].surfel_count = kMaxCompactLeafSurfels + 1;
  EXPECT_THROW(encode_leaf_section(zero, out), Error);
}

}  // namespace
}  // namespace pbgi::storage
