// Pixel error metrics of a test image against a reference, over one group of
// channels (an AOV: rgb or a single channel).
//
// Definitions, over the N = pixels x channels values (t_i test, r_i
// reference) that are finite in both images:
//   MSE     = (1/N) sum (t_i - r_i)^2
//   RMSE    = sqrt(MSE)
//   PSNR    = 10 log10(peak^2 / MSE) dB with peak = max_i r_i, the largest
//             reference value of the group (not 1: renders are HDR, so a
//             fixed peak would make PSNR depend on exposure). +inf when
//             MSE = 0; NaN when peak <= 0 and MSE > 0 (no meaningful scale).
//   relMSE  = (1/N) sum (t_i - r_i)^2 / (r_i^2 + eps), eps = 0.01 by
//             default (Rousselle et al. 2011): an error relative to the
//             local brightness, so dark regions count as much as bright.
//   bias    = (1/N) sum (t_i - r_i), the mean signed difference.
// Values non-finite in either image are skipped and counted.
//
// Thread-safety: pure functions.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>

namespace pbgi::metrics {

struct ErrorOptions {
  // eps of relMSE, in the images' units squared (> 0).
  double rel_mse_epsilon = 1e-2;
};

struct ErrorMetrics {
  uint64_t values = 0;     // finite values compared
  uint64_t nonfinite = 0;  // values skipped (NaN/inf in either image)
  double mse = 0, rmse = 0, rel_mse = 0, bias = 0;
  // RMSE relative to the reference's root mean square, sqrt(sum d^2 /
  // sum r^2): one number for "how far off" whatever the image's scale.
  double rel_rmse = 0;
  double psnr = std::numeric_limits<double>::quiet_NaN();
  double peak = 0;           // max reference value (PSNR's peak)
  double mean_test = 0, mean_reference = 0;
};

// Compares `count` values (all channels of a group, any layout, as long as
// test and reference use the same one). Throws InvalidArgument if eps <= 0.
ErrorMetrics error_metrics(const float* test, const float* reference, size_t count,
                           const ErrorOptions& options = {});

}  // namespace pbgi::metrics
