#include "client/metrics/error_metrics.h"

#include "common/errors.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace pbgi::metrics {
namespace {

TEST(ErrorMetrics, IdenticalImagesHaveZeroErrorAndInfinitePsnr) {
  std::vector<float> a{0.1f, 0.5f, 2.f, 0.f};
  const ErrorMetrics m = error_metrics(a.data(), a.data(), a.size());
  EXPECT_EQ(m.values, 4u);
  EXPECT_EQ(m.mse, 0.0);
  EXPECT_EQ(m.rmse, 0.0);
  EXPECT_EQ(m.rel_mse, 0.0);
  EXPECT_TRUE(std::isinf(m.psnr) && m.psnr > 0);
  EXPECT_EQ(m.peak, 2.0);
}

TEST(ErrorMetrics, ConstantOffsetGivesKnownValues) {
  // Reference in [0, 1] with max 1; test = reference + 0.1.
  std::vector<float> ref{0.f, 0.25f, 0.5f, 1.f}, test;
  for (float r : ref) test.push_back(r + 0.1f);
  const ErrorMetrics m = error_metrics(test.data(), ref.data(), ref.size());
  EXPECT_NEAR(m.mse, 0.01, 1e-7);
  EXPECT_NEAR(m.rmse, 0.1, 1e-6);
  EXPECT_NEAR(m.psnr, 20.0, 1e-4);  // 10 log10(1 / 0.01)
  EXPECT_NEAR(m.bias, 0.1, 1e-6);
  double rel = 0;
  for (float r : ref) rel += 0.01 / (double(r) * r + 0.01);
  EXPECT_NEAR(m.rel_mse, rel / 4, 1e-6);
  EXPECT_NEAR(m.mean_reference, 0.4375, 1e-7);
  EXPECT_NEAR(m.mean_test, 0.5375, 1e-6);
}

TEST(ErrorMetrics, PsnrPeakIsTheReferenceMaximum) {
  // Same error, reference twice as bright: PSNR rises by 20 log10(2).
  std::vector<float> ref{0.f, 2.f}, test{0.5f, 2.f};
  const ErrorMetrics m = error_metrics(test.data(), ref.data(), 2);
  EXPECT_NEAR(m.mse, 0.125, 1e-9);
  EXPECT_NEAR(m.psnr, 10 * std::log10(4.0 / 0.125), 1e-6);
  // A black reference has no scale for PSNR.
  std::vector<float> black{0.f, 0.f};
  EXPECT_TRUE(std::isnan(error_metrics(test.data(), black.data(), 2).psnr));
}

TEST(ErrorMetrics, RelativeMseWeighsDarkRegions) {
  // The same absolute error counts 100x more where the reference is dark.
  std::vector<float> ref{0.f, 1.f}, test{0.01f, 1.01f};
  ErrorOptions o;
  o.rel_mse_epsilon = 1e-4;
  const ErrorMetrics m = error_metrics(test.data(), ref.data(), 2, o);
  EXPECT_NEAR(m.rel_mse, 0.5 * (1e-4 / 1e-4 + 1e-4 / (1 + 1e-4)), 1e-7);
  o.rel_mse_epsilon = 0;
  EXPECT_THROW(error_metrics(test.data(), ref.data(), 2, o), InvalidArgument);
}

TEST(ErrorMetrics, NonFiniteValuesAreSkippedAndCounted) {
  std::vector<float> ref{1.f, 1.f, NAN}, test{1.f, INFINITY, 5.f};
  const ErrorMetrics m = error_metrics(test.data(), ref.data(), 3);
  EXPECT_EQ(m.values, 1u);
  EXPECT_EQ(m.nonfinite, 2u);
  EXPECT_EQ(m.mse, 0.0);
}

}  // namespace
}  // namespace pbgi::metrics
