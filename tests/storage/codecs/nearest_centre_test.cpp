#include "storage/codecs/nearest_centre.h"
#include "common/errors.h"
#include "storage/codecs/pca_basis.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace pbgi::storage {
namespace {

std::vector<float> gaussian(size_t count, size_t dims, uint32_t seed, float anisotropy) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> g;
  std::vector<float> v(count * dims);
  for (size_t i = 0; i < count; ++i)
    for (size_t k = 0; k < dims; ++k) v[i * dims + k] = g(rng) * std::pow(anisotropy, -float(k));
  return v;
}

// The pruned search returns exactly the brute-force answer (same distance,
// same index) on random data, with and without hints, in several dimensions.
TEST(NearestCentre, ExactAgainstBruteForce) {
  for (size_t dims : {1u, 3u, 8u, 36u, 41u}) {
    for (size_t count : {1u, 2u, 129u, 2000u}) {
      const auto centres = gaussian(count, dims, uint32_t(dims * 7 + count), 1.1f);
      const NearestCentreTable t(centres, dims);
      const auto queries = gaussian(300, dims, 99, 1.1f);
      for (size_t q = 0; q < 300; ++q) {
        const float* x = &queries[q * dims];
        const NearestResult bf = t.brute_force(x);
        const NearestResult a = t.search(x);
        const NearestResult b = t.search(x, uint32_t(q % count));
        ASSERT_EQ(a.index, bf.index) << dims << " " << count << " " << q;
        ASSERT_EQ(a.distance2, bf.distance2);
        ASSERT_EQ(b.index, bf.index);
        // The brute force is a true minimum over the centres.
        for (size_t c = 0; c < count; ++c) {
          double d = 0;
          for (size_t k = 0; k < dims; ++k) d += double(x[k] - centres[c * dims + k]) * (x[k] - centres[c * dims + k]);
          ASSERT_GE(d, double(bf.distance2) * (1 - 1e-5) - 1e-12);
        }
      }
    }
  }
}

TEST(NearestCentre, TiesGoToTheLowerIndexAndCentresAreFound) {
  // Duplicated centres: every query ties; the lower index must win.
  std::vector<float> c = {1, 2, 3, 1, 2, 3, 0, 0, 0, 1, 2, 3};
  const NearestCentreTable t(c, 3);
  const float q[3] = {1, 2, 3.1f};
  EXPECT_EQ(t.search(q).index, 0u);
  EXPECT_EQ(t.search(q, 3).index, 0u);
  EXPECT_EQ(t.brute_force(q).index, 0u);
  // A centre queried exactly is at distance 0.
  const auto centres = gaussian(500, 36, 4, 1.f);
  const NearestCentreTable t2(centres, 36);
  for (uint32_t i = 0; i < 500; ++i) {
    const NearestResult r = t2.search(&centres[i * 36]);
    EXPECT_EQ(r.distance2, 0.f);
    EXPECT_EQ(r.index, i);
  }
}

TEST(NearestCentre, RejectsBadInput) {
  EXPECT_THROW(NearestCentreTable({}, 3), InvalidArgument);
  EXPECT_THROW(NearestCentreTable(std::vector<float>(7), 3), InvalidArgument);
}

TEST(PcaBasis, OrthonormalAndOrderedByVariance) {
  const size_t dims = 12;
  auto v = gaussian(5000, dims, 8, 1.3f);
  // Mix the coordinates so the axes are not the input axes.
  for (size_t i = 0; i < 5000; ++i) {
    float* x = &v[i * dims];
    const float a = x[0], b = x[5];
    x[0] = 0.6f * a + 0.8f * b;
    x[5] = -0.8f * a + 0.6f * b;
    x[3] += 10.f;
  }
  const PcaBasis b = PcaBasis::fit(v, dims);
  for (size_t k = 1; k < dims; ++k) EXPECT_GE(b.variances()[k - 1], b.variances()[k]);
  EXPECT_NEAR(b.variances()[0], 1.0, 0.08);  // the largest input variance
  // Rotation preserves distances and unrotate inverts it.
  float r0[dims], r1[dims], back[dims];
  b.rotate(&v[0], r0);
  b.rotate(&v[dims], r1);
  b.unrotate(r0, back);
  double d_in = 0, d_out = 0;
  for (size_t k = 0; k < dims; ++k) {
    d_in += double(v[k] - v[dims + k]) * (v[k] - v[dims + k]);
    d_out += double(r0[k] - r1[k]) * (r0[k] - r1[k]);
    EXPECT_NEAR(back[k], v[k], 1e-4f);
  }
  EXPECT_NEAR(d_in, d_out, 1e-4 * d_in);
}

}  // namespace
}  // namespace pbgi::storage
