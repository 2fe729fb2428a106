#include "client/bench/equal_error.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace pbgi::bench {
namespace {

// A Monte Carlo sweep: MSE = 1/spp, 0.01 s per spp.
std::vector<SweepPoint> ideal_sweep() {
  std::vector<SweepPoint> p;
  for (double spp = 1; spp <= 64; spp *= 2) p.push_back({spp, 0.01 * spp, 1.0 / spp});
  return p;
}

TEST(EqualError, InterpolatesInLogLogSpace) {
  // On a power law the log-log interpolation is exact.
  const EqualErrorPoint e = equal_error_point(ideal_sweep(), 1.0 / 12.0);
  ASSERT_TRUE(e.valid);
  EXPECT_FALSE(e.extrapolated);
  EXPECT_NEAR(e.spp, 12.0, 1e-9);
  EXPECT_NEAR(e.seconds, 0.12, 1e-9);
}

TEST(EqualError, HitsSweepPointsExactly) {
  const EqualErrorPoint e = equal_error_point(ideal_sweep(), 1.0 / 16.0);
  ASSERT_TRUE(e.valid);
  EXPECT_DOUBLE_EQ(e.spp, 16.0);
  EXPECT_DOUBLE_EQ(e.seconds, 0.16);
}

TEST(EqualError, ExtrapolatesWithTheMonteCarloRate) {
  // Below the sweep's smallest error: from the 64-spp end.
  EqualErrorPoint e = equal_error_point(ideal_sweep(), 1.0 / 256.0);
  ASSERT_TRUE(e.valid);
  EXPECT_TRUE(e.extrapolated);
  EXPECT_NEAR(e.spp, 256.0, 1e-9);
  EXPECT_NEAR(e.seconds, 2.56, 1e-9);
  // Above the 1-spp error: fewer than one sample's worth of time.
  e = equal_error_point(ideal_sweep(), 4.0);
  ASSERT_TRUE(e.valid);
  EXPECT_TRUE(e.extrapolated);
  EXPECT_NEAR(e.spp, 0.25, 1e-12);
  EXPECT_NEAR(e.seconds, 0.0025, 1e-12);
}

TEST(EqualError, TakesTheFirstCrossingOfANoisySweep) {
  // Unordered input, MSE not monotone: 1 -> 0.4 -> 0.6 -> 0.2.
  std::vector<SweepPoint> p{{4, 0.4, 0.6}, {1, 0.1, 1.0}, {8, 0.8, 0.2}, {2, 0.2, 0.4}};
  // 0.5 is crossed three times; the cheapest crossing is between 1 and 2 spp.
  EqualErrorPoint e = equal_error_point(p, 0.5);
  ASSERT_TRUE(e.valid);
  EXPECT_FALSE(e.extrapolated);
  EXPECT_GT(e.spp, 1.0);
  EXPECT_LT(e.spp, 2.0);
  // 0.3 only between 4 and 8.
  e = equal_error_point(p, 0.3);
  EXPECT_GT(e.spp, 4.0);
  EXPECT_LT(e.spp, 8.0);
}

TEST(EqualError, RemovesTheReferenceNoiseFloor) {
  // Measured against a reference of finite spp, every MSE carries its
  // variance: MSE = 1/spp + 0.01. With the floor removed the power law is
  // exact again, and PBGI's measured 0.01 + 1/12 matches 12 spp.
  std::vector<SweepPoint> p = ideal_sweep();
  for (SweepPoint& s : p) s.mse += 0.01;
  const EqualErrorPoint e = equal_error_point(p, 0.01 + 1.0 / 100.0, 0.01);
  ASSERT_TRUE(e.valid);
  EXPECT_TRUE(e.extrapolated);  // beyond 64 spp
  EXPECT_NEAR(e.spp, 100.0, 1e-6);
  EXPECT_NEAR(equal_error_point(p, 0.01 + 1.0 / 12.0, 0.01).spp, 12.0, 1e-9);
  // A target within the noise has no answer.
  EXPECT_FALSE(equal_error_point(p, 0.009, 0.01).valid);
  EXPECT_FALSE(equal_error_point(p, 0.5, -1.0).valid);
}

TEST(EqualError, IgnoresUnusablePoints) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(equal_error_point({}, 0.1).valid);
  EXPECT_FALSE(equal_error_point(ideal_sweep(), 0.0).valid);
  EXPECT_FALSE(equal_error_point(ideal_sweep(), nan).valid);
  EXPECT_FALSE(equal_error_point({{1, 0.1, 0.0}, {2, 0.2, nan}}, 0.1).valid);
  std::vector<SweepPoint> p = ideal_sweep();
  p.push_back({128, 1.28, nan});  // would otherwise be the low end
  EXPECT_FALSE(equal_error_point(p, 1.0 / 32).extrapolated);
}

TEST(Pareto, FlagsTheNonDominatedPoints) {
  //            fast+bad  slow+good  dominated  tie-in-time-worse  best-of-both
  const std::vector<double> t{1, 10, 5, 10, 3};
  const std::vector<double> e{10, 1, 8, 2, 4};
  const std::vector<bool> p = pareto_optimal(t, e);
  EXPECT_EQ(p, (std::vector<bool>{true, true, false, false, true}));
}

TEST(Pareto, EqualPointsAreBothOptimalAndNaNIsNever) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<bool> p = pareto_optimal({1, 1, nan, 0.1}, {2, 2, 0.0, nan});
  EXPECT_EQ(p, (std::vector<bool>{true, true, false, false}));
  EXPECT_THROW(pareto_optimal({1}, {1, 2}), std::exception);
}

TEST(FrontSecondsAtError, InterpolatesLogLogOnTheParetoFront) {
  // A curve with MSE ~ 1/seconds^2 (exact in log-log), one dominated point
  // (slower and worse) that must not be bracketed.
  const std::vector<SweepPoint> curve{{0, 1, 1.0}, {0, 4, 0.0625}, {0, 3, 2.0}, {0, 2, 0.25}};
  EXPECT_NEAR(front_seconds_at_error(curve, 0.25), 2.0, 1e-12);     // a point
  EXPECT_NEAR(front_seconds_at_error(curve, 0.5), std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(front_seconds_at_error(curve, 0.125), std::sqrt(8.0), 1e-12);
}

TEST(FrontSecondsAtError, NeverExtrapolates) {
  const std::vector<SweepPoint> curve{{0, 1, 1.0}, {0, 2, 0.25}};
  EXPECT_EQ(front_seconds_at_error(curve, 2.0), 0.0);   // worse than the fastest
  EXPECT_EQ(front_seconds_at_error(curve, 0.1), 0.0);   // better than the best
  EXPECT_EQ(front_seconds_at_error({}, 0.5), 0.0);
  EXPECT_EQ(front_seconds_at_error(curve, std::numeric_limits<double>::quiet_NaN()), 0.0);
}

}  // namespace
}  // namespace pbgi::bench
