#include "client/metrics/error_metrics.h"

#include "common/errors.h"

#include <cmath>
#include <string>

namespace pbgi::metrics {

ErrorMetrics error_metrics(const float* test, const float* reference, size_t count,
                           const ErrorOptions& options) {
  if (!(options.rel_mse_epsilon > 0.0))
    throw InvalidArgument("ErrorOptions.rel_mse_epsilon must be > 0 (got " +
                          std::to_string(options.rel_mse_epsilon) + ")");
  ErrorMetrics m;
  // Double sums: images have millions of values of very different size.
  double se = 0, rel = 0, diff = 0, st = 0, sr = 0, sr2 = 0;
  double peak = -std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < count; ++i) {
    const double t = test[i], r = reference[i];
    if (!std::isfinite(t) || !std::isfinite(r)) {
      ++m.nonfinite;
      continue;
    }
    const double d = t - r;
    se += d * d;
    rel += d * d / (r * r + options.rel_mse_epsilon);
    diff += d;
    st += t;
    sr += r;
    sr2 += r * r;
    if (r > peak) peak = r;
    ++m.values;
  }
  if (m.values == 0) return m;
  const double n = double(m.values);
  m.mse = se / n;
  m.rmse = std::sqrt(m.mse);
  m.rel_mse = rel / n;
  m.rel_rmse = sr2 > 0.0 ? std::sqrt(se / sr2) : (se > 0.0 ? std::numeric_limits<double>::infinity() : 0.0);
  m.bias = diff / n;
  m.mean_test = st / n;
  m.mean_reference = sr / n;
  m.peak = peak;
  if (m.mse == 0.0)
    m.psnr = std::numeric_limits<double>::infinity();
  else if (peak > 0.0)
    m.psnr = 10.0 * std::log10(peak * peak / m.mse);
  return m;
}

}  // namespace pbgi::metrics
