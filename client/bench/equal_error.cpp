#include "client/bench/equal_error.h"

#include "common/errors.h"

#include <algorithm>
#include <cmath>

namespace pbgi::bench {
namespace {

bool usable(const SweepPoint& p) {
  return std::isfinite(p.spp) && std::isfinite(p.seconds) && std::isfinite(p.mse) && p.spp > 0 &&
         p.seconds > 0 && p.mse > 0;
}

// From `p` along the Monte Carlo rate: MSE * spp constant, seconds / spp
// constant.
EqualErrorPoint along_rate(const SweepPoint& p, double target) {
  EqualErrorPoint e;
  e.valid = true;
  e.extrapolated = true;
  e.spp = p.spp * p.mse / target;
  e.seconds = p.seconds * e.spp / p.spp;
  return e;
}

}  // namespace

EqualErrorPoint equal_error_point(std::vector<SweepPoint> points, double target,
                                  double noise_floor) {
  if (!(noise_floor >= 0) || !std::isfinite(noise_floor)) return {};
  for (SweepPoint& p : points) p.mse -= noise_floor;
  target -= noise_floor;
  points.erase(std::remove_if(points.begin(), points.end(), [](const SweepPoint& p) { return !usable(p); }),
               points.end());
  if (points.empty() || !std::isfinite(target) || target <= 0) return {};
  std::stable_sort(points.begin(), points.end(),
                   [](const SweepPoint& a, const SweepPoint& b) { return a.spp < b.spp; });

  // 1. The first bracketing segment, from low spp (noise may make the MSE
  // of a sweep slightly non-monotone; the first crossing is the cheapest).
  for (size_t i = 0; i < points.size(); ++i) {
    const SweepPoint& a = points[i];
    if (a.mse == target) return {true, a.spp, a.seconds, false};
    if (i + 1 == points.size()) break;
    const SweepPoint& b = points[i + 1];
    const bool brackets = (a.mse - target) * (b.mse - target) < 0;
    if (!brackets) continue;
    const double f = (std::log(target) - std::log(a.mse)) / (std::log(b.mse) - std::log(a.mse));
    EqualErrorPoint e;
    e.valid = true;
    e.spp = std::exp(std::log(a.spp) + f * (std::log(b.spp) - std::log(a.spp)));
    e.seconds = std::exp(std::log(a.seconds) + f * (std::log(b.seconds) - std::log(a.seconds)));
    return e;
  }
  // 2. Outside the range: from the end nearer in error.
  const auto [lo, hi] = std::minmax_element(points.begin(), points.end(),
                                            [](const SweepPoint& a, const SweepPoint& b) {
                                              return a.mse < b.mse;
                                            });
  return along_rate(target < lo->mse ? *lo : *hi, target);
}

double front_seconds_at_error(const std::vector<SweepPoint>& points, double target) {
  if (!std::isfinite(target) || target <= 0) return 0.0;
  std::vector<double> t, e;
  for (const SweepPoint& p : points)
    if (std::isfinite(p.seconds) && std::isfinite(p.mse) && p.seconds > 0 && p.mse > 0) {
      t.push_back(p.seconds);
      e.push_back(p.mse);
    }
  const std::vector<bool> optimal = pareto_optimal(t, e);
  std::vector<SweepPoint> front;
  for (size_t i = 0; i < t.size(); ++i)
    if (optimal[i]) front.push_back({0, t[i], e[i]});
  // On the front, MSE falls as seconds grow.
  std::sort(front.begin(), front.end(),
            [](const SweepPoint& a, const SweepPoint& b) { return a.seconds < b.seconds; });
  for (size_t i = 0; i < front.size(); ++i) {
    const SweepPoint& a = front[i];
    if (a.mse == target) return a.seconds;
    if (i + 1 == front.size()) break;
    const SweepPoint& b = front[i + 1];
    if ((a.mse - target) * (b.mse - target) >= 0) continue;
    const double f = (std::log(target) - std::log(a.mse)) / (std::log(b.mse) - std::log(a.mse));
    return std::exp(std::log(a.seconds) + f * (std::log(b.seconds) - std::log(a.seconds)));
  }
  return 0.0;
}

std::vector<bool> pareto_optimal(const std::vector<double>& seconds,
                                 const std::vector<double>& error) {
  if (seconds.size() != error.size())
    throw InvalidArgument("pareto_optimal: " + std::to_string(seconds.size()) + " times but " +
                          std::to_string(error.size()) + " errors");
  const size_t n = seconds.size();
  auto finite = [&](size_t i) { return std::isfinite(seconds[i]) && std::isfinite(error[i]); };
  std::vector<bool> optimal(n, false);
  for (size_t i = 0; i < n; ++i) {
    if (!finite(i)) continue;
    bool dominated = false;
    for (size_t j = 0; j < n && !dominated; ++j) {
      if (j == i || !finite(j)) continue;
      dominated = seconds[j] <= seconds[i] && error[j] <= error[i] &&
                  (seconds[j] < seconds[i] || error[j] < error[i]);
    }
    optimal[i] = !dominated;
  }
  return optimal;
}

}  // namespace pbgi::bench
