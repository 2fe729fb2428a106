// The analysis of a sweep: where a sampling method reaches a given error
// (interpolated in log-log between sweep points) and which configurations
// are Pareto-optimal in time and error.
//
// Thread-safety: pure functions.
#pragma once

#include <vector>

namespace pbgi::bench {

struct SweepPoint {
  double spp = 0;
  double seconds = 0;
  double mse = 0;
};

struct EqualErrorPoint {
  bool valid = false;         // false: no usable point (non-positive or non-finite)
  double spp = 0, seconds = 0;
  bool extrapolated = false;  // target outside the points' MSE range
};

// The (spp, seconds) at which a Monte Carlo sweep's MSE equals `target_mse`.
// `noise_floor` (>= 0) is first subtracted from every MSE and the target:
// measured against a reference of finite spp, MSE = s^2/spp + floor, so
// without the floor the sweep is an exact power law. Points are taken in
// order of spp; points with a non-finite or non-positive spp, seconds or
// (floor-corrected) MSE are ignored; a target at or below the floor has no
// answer (invalid). The first segment (from low
// spp) whose MSE brackets the target is interpolated linearly in
// (log MSE) -> (log spp, log seconds). A target below every point's MSE
// (or above) is extrapolated from the nearest end with MSE ~ 1/spp and
// seconds ~ spp, the Monte Carlo rate, and flagged.
EqualErrorPoint equal_error_point(std::vector<SweepPoint> points, double target_mse,
                                  double noise_floor = 0.0);

// The seconds at which a deterministic method's curve (points: seconds and
// MSE; spp ignored) reaches `target_mse`: over the points' Pareto front,
// sorted by seconds, interpolated linearly in log-log between the two front
// points whose MSE brackets the target (a point at exactly the target: its
// seconds). 0 when the target lies outside the front's MSE range: a gather's
// error follows no known rate, so nothing is extrapolated.
double front_seconds_at_error(const std::vector<SweepPoint>& points, double target_mse);

// Pareto flags of (seconds, error) points to be minimized together: a point
// is optimal unless another has seconds <= and error <=, one strictly.
// Points with a non-finite coordinate are never optimal and dominate none.
std::vector<bool> pareto_optimal(const std::vector<double>& seconds,
                                 const std::vector<double>& error);

}  // namespace pbgi::bench
