// The glossy radiance section (storage/codecs/glossy_section.h): a round
// trip keeps every coefficient within half precision of its block's
// largest, zero blocks and zero coefficients cost only their bitmap, and
// damaged or foreign bytes are refused.
#include "storage/codecs/glossy_section.h"

#include "common/errors.h"
#include "storage/codecs/cube_wavelet.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace pbgi::storage {
namespace {

// A code of `nodes` nodes (node 0 the root with its average; odd nodes
// keep some detail faces) with sparse, HDR-ranged coefficients.
WaveletTreeCode sample_code(uint32_t n, uint32_t nodes, uint32_t seed) {
  const CubeLayout layout{n};
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  WaveletTreeCode c;
  c.dims = layout.floats();
  c.block_floats = uint32_t(layout.face_floats());
  c.average_levels = 0;
  c.threshold = 0.25f;
  c.average_at.assign(nodes, WaveletTreeCode::kNone);
  c.average_at[0] = 0;
  c.has_detail.assign(nodes, 0);
  c.detail_mask.assign(nodes, 0);
  c.detail_at.assign(nodes, 0);
  auto value = [&] { return u(rng) < 0.2f ? (u(rng) - 0.5f) * std::pow(10.f, 4.f * u(rng)) : 0.f; };
  c.averages.resize(c.dims);
  for (float& x : c.averages) x = value();
  for (uint32_t i = 0; i < nodes; ++i) {
    if (i % 2 == 0) continue;
    c.has_detail[i] = 1;
    c.detail_mask[i] = uint32_t(rng()) & 0x3f;
    c.detail_at[i] = c.details.size();
    for (int f = 0; f < 6; ++f)
      if (c.detail_mask[i] >> f & 1u)
        for (size_t k = 0; k < c.block_floats; ++k) c.details.push_back(value());
  }
  return c;
}

// Largest |v| per block, for the error bound.
float block_max(const float* v, size_t n) {
  float m = 0.f;
  for (size_t i = 0; i < n; ++i) m = std::max(m, std::abs(v[i]));
  return m;
}

TEST(GlossySection, RoundTripWithinHalfPrecisionOfEachBlock) {
  for (uint32_t n : {8u, 16u}) {
    const WaveletTreeCode c = sample_code(n, 9, n);
    const std::vector<uint8_t> bytes = write_glossy_section(c, n);
    uint32_t res = 0;
    const WaveletTreeCode d = read_glossy_section(bytes, "test", res);
    EXPECT_EQ(res, n);
    ASSERT_EQ(d.dims, c.dims);
    ASSERT_EQ(d.details.size(), c.details.size());
    EXPECT_EQ(d.detail_mask, c.detail_mask);
    EXPECT_EQ(d.has_detail, c.has_detail);
    EXPECT_EQ(d.threshold, c.threshold);
    const size_t bf = c.block_floats;
    auto check = [&](const float* a, const float* b) {
      const float bound = block_max(a, bf) * std::ldexp(1.f, -11);
      for (size_t i = 0; i < bf; ++i) ASSERT_LE(std::abs(a[i] - b[i]), bound) << i;
    };
    for (uint32_t f = 0; f < 6; ++f) check(c.averages.data() + f * bf, d.averages.data() + f * bf);
    for (size_t at = 0; at < c.details.size(); at += bf) check(c.details.data() + at, d.details.data() + at);
    // Sparse blocks cost far less than dense float32 ones.
    EXPECT_LT(bytes.size(), (6 + c.details.size() / bf) * bf * sizeof(float) / 3);
  }
}

TEST(GlossySection, DenormalAndNonFiniteBlocksAreStoredAsZero) {
  WaveletTreeCode c = sample_code(8, 3, 5);
  const size_t bf = c.block_floats;
  std::fill(c.averages.begin(), c.averages.begin() + bf, 0.f);
  c.averages[1] = 1e-39f;  // denormal: 1 / scale would overflow
  c.averages[bf + 2] = std::nanf("");
  uint32_t res = 0;
  const WaveletTreeCode d = read_glossy_section(write_glossy_section(c, 8), "test", res);
  for (size_t i = 0; i < bf; ++i) EXPECT_EQ(d.averages[i], 0.f) << i;
  for (size_t i = bf; i < 2 * bf; ++i) EXPECT_TRUE(std::isfinite(d.averages[i])) << i;
}

TEST(GlossySection, DamagedOrForeignBytesAreRefused) {
  const std::vector<uint8_t> bytes = write_glossy_section(sample_code(8, 5, 3), 8);
  uint32_t res = 0;
  for (size_t at : {size_t(0), size_t(13), bytes.size() / 2, bytes.size() - 1}) {
    std::vector<uint8_t> bad = bytes;
    bad[at] ^= 0x40;
    EXPECT_THROW(read_glossy_section(bad, "test", res), CorruptionError) << at;
  }
  EXPECT_THROW(read_glossy_section(std::span(bytes).first(20), "test", res), CorruptionError);
  WaveletTreeCode wrong = sample_code(8, 5, 3);
  wrong.average_levels = 2;
  EXPECT_THROW(write_glossy_section(wrong, 8), InvalidArgument);
  EXPECT_THROW(write_glossy_section(sample_code(8, 5, 3), 16), InvalidArgument);
}

}  // namespace
}  // namespace pbgi::storage
