#include "storage/codecs/kmeans.h"
#include "common/errors.h"
#include "storage/codecs/nearest_centre.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <set>

namespace pbgi::storage {
namespace {

// Points around `blobs` random centres in `dims` dimensions.
std::vector<float> blobs(size_t count, size_t dims, size_t blobs, float spread, uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> g;
  std::vector<float> c(blobs * dims);
  for (auto& x : c) x = 5.f * g(rng);
  std::vector<float> v(count * dims);
  for (size_t i = 0; i < count; ++i) {
    const size_t b = rng() % blobs;
    for (size_t k = 0; k < dims; ++k) v[i * dims + k] = c[b * dims + k] + spread * g(rng);
  }
  return v;
}

double objective(const std::vector<float>& pts, size_t dims, const KMeansResult& r) {
  double s = 0;
  for (size_t i = 0; i < pts.size() / dims; ++i)
    for (size_t k = 0; k < dims; ++k) {
      const double d = pts[i * dims + k] - r.centres[r.assignment[i] * dims + k];
      s += d * d;
    }
  return s;
}

TEST(KMeans, ObjectiveDecreasesMonotonically) {
  for (uint32_t seed : {1u, 2u, 3u}) {
    const auto pts = blobs(6000, 36, 300, 0.5f, seed);
    KMeansOptions o;
    o.clusters = 256;
    o.max_iterations = 20;
    o.min_improvement = 0;  // run every iteration
    o.seed = seed;
    const KMeansResult r = kmeans(pts, 36, o);
    ASSERT_EQ(r.size(), 256u);
    ASSERT_EQ(r.objective.size(), r.iterations + 1);
    EXPECT_GE(r.iterations, 2u);
    for (size_t i = 1; i < r.objective.size(); ++i) {
      EXPECT_LE(r.objective[i], r.objective[i - 1] * (1 + 1e-12)) << "iteration " << i;
    }
    EXPECT_LT(r.objective.back(), r.objective.front());
    // The reported objective is the true one of the returned clustering
    // (computed in the input coordinates: agreement to rounding).
    EXPECT_NEAR(objective(pts, 36, r), r.objective.back(), 1e-3 * r.objective.back());
    // Every assignment is the nearest centre.
    const NearestCentreTable t(r.centres, 36);
    for (size_t i = 0; i < 6000; i += 37) {
      const NearestResult n = t.brute_force(&pts[i * 36]);
      double d_assigned = 0;
      for (size_t k = 0; k < 36; ++k) {
        const double d = pts[i * 36 + k] - r.centres[r.assignment[i] * 36 + k];
        d_assigned += d * d;
      }
      EXPECT_LE(d_assigned, double(n.distance2) * (1 + 1e-4) + 1e-9);
    }
  }
}

TEST(KMeans, FindsSeparatedBlobs) {
  // 16 tight, well separated blobs and 16 clusters: k-means++ + Lloyd put one
  // centre in each, so the objective is about the blob variance.
  const size_t dims = 8;
  const auto pts = blobs(4000, dims, 16, 0.01f, 11);
  KMeansOptions o;
  o.clusters = 16;
  const KMeansResult r = kmeans(pts, dims, o);
  const double per_point = r.objective.back() / 4000.0;
  EXPECT_LT(per_point, 0.01 * 0.01 * dims * 3);
}

TEST(KMeans, FewerDistinctPointsThanClusters) {
  // 10 distinct points (each repeated): at most 10 centres, objective 0.
  std::vector<float> pts;
  for (int rep = 0; rep < 5; ++rep)
    for (int i = 0; i < 10; ++i) pts.insert(pts.end(), {float(i), float(i * i), 1.f});
  KMeansOptions o;
  o.clusters = 128;
  const KMeansResult r = kmeans(pts, 3, o);
  EXPECT_EQ(r.size(), 10u);
  EXPECT_EQ(r.objective.back(), 0.0);
}

TEST(KMeans, EmptyClustersAreReseeded) {
  // Two clumps and four starting centres, two of them far from every point:
  // their clusters are empty from the start and must be re-seeded at the
  // points farthest from their centres, which lowers the objective.
  std::vector<float> pts;
  std::mt19937 rng(2);
  std::normal_distribution<float> g;
  for (int i = 0; i < 500; ++i) pts.insert(pts.end(), {g(rng), g(rng)});
  for (int i = 0; i < 500; ++i) pts.insert(pts.end(), {50.f + g(rng), g(rng)});
  KMeansOptions o;
  o.initial_centres = {25.f, 0.f, 1000.f, 1000.f, -1000.f, 1000.f, 25.f, 1.f};
  o.min_improvement = 0;
  const KMeansResult r = kmeans(pts, 2, o);
  ASSERT_EQ(r.size(), 4u);
  EXPECT_GE(r.reseeded, 2u);
  std::set<uint32_t> used(r.assignment.begin(), r.assignment.end());
  EXPECT_EQ(used.size(), 4u);
  for (size_t i = 1; i < r.objective.size(); ++i) EXPECT_LE(r.objective[i], r.objective[i - 1] * (1 + 1e-12));
  // Two clumps of unit variance in 2D, four centres: well below one centre
  // per clump (2 per point) and far below the start.
  EXPECT_LT(r.objective.back() / 1000.0, 1.5);
  EXPECT_LT(r.objective.back(), 0.01 * r.objective.front());
}

TEST(KMeans, DeterministicAndValidated) {
  const auto pts = blobs(2000, 9, 50, 0.3f, 5);
  KMeansOptions o;
  o.clusters = 64;
  const KMeansResult a = kmeans(pts, 9, o), b = kmeans(pts, 9, o);
  EXPECT_EQ(a.centres, b.centres);
  EXPECT_EQ(a.assignment, b.assignment);
  o.clusters = 0;
  EXPECT_THROW(kmeans(pts, 9, o), InvalidArgument);
  o.clusters = 4;
  auto bad = pts;
  bad[17] = std::nanf("");
  EXPECT_THROW(kmeans(bad, 9, o), InvalidArgument);
  EXPECT_THROW(kmeans(std::vector<float>(10), 9, o), InvalidArgument);
}

}  // namespace
}  // namespace pbgi::storage
