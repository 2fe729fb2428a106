// What one `pbgi bench` run measured: a row per configuration, a record per
// build, the reference, and the equal-error figure (the path tracer's cost
// at PBGI's error). Written as bench.json / bench.csv by bench_report.h.
#pragma once

#include "client/bench/bench_method.h"
#include "client/metrics/error_metrics.h"

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace pbgi::bench {

// Error of one AOV against the reference.
struct AovError {
  metrics::ErrorMetrics error;     // MSE, RMSE, PSNR, relMSE, ...
  uint64_t pdiff_pixels = 0;       // perceptual_diff: pixels a viewer sees differ
  double pdiff_fraction = 0.0;
};

struct BenchRow {
  std::string method, name, series, build;
  std::vector<Param> params;
  uint32_t spp = 0;
  bool is_default = false;
  bool equal_error_point = false, default_curve = false;  // MethodConfig's
  // Wall-clock seconds (stopwatch.h): the render alone, its build + load
  // (0 without a build), and their sum.
  double render_seconds = 0.0, build_seconds = 0.0, total_seconds = 0.0;
  // The same as process CPU seconds (all threads).
  double render_cpu_seconds = 0.0, build_cpu_seconds = 0.0, total_cpu_seconds = 0.0;
  AovError indirect, beauty;
  // Not dominated by another row (lower-or-equal render time and MSE, one
  // of them strictly), per AOV.
  bool pareto_indirect = false, pareto_beauty = false;
};

struct BuildRecord {
  std::string name;
  std::vector<Param> params;
  std::vector<Param> facts;       // BuiltState::describe()
  double build_seconds = 0.0;     // BuildSpec::build, wall clock
  double load_seconds = 0.0;      // BuiltState::load, wall clock
  double build_cpu_seconds = 0.0, load_cpu_seconds = 0.0;
};

struct ReferenceRecord {
  uint32_t spp = 0;
  uint64_t seed = 0;
  double seconds = 0.0;           // render time when it was made (cached: then)
  double cpu_seconds = 0.0;       // its CPU time
  bool cached = false;            // read from the cache in this run
  std::string key;
  std::filesystem::path file;
  // Estimated MSE of the reference itself (its variance: the path tracer's
  // largest-spp MSE scaled by spp / reference spp). Every row's MSE
  // includes about this much; it bounds the smallest error measurable.
  double noise_mse_indirect = 0.0, noise_mse_beauty = 0.0;
};

// The path tracer's cost at the error of PBGI's default configuration.
// Every measured MSE includes the reference's own variance (noise_floor,
// see ReferenceRecord); it is subtracted from PBGI's MSE and the path
// tracer's before they are matched, so that a noisy reference does not
// flatter either side (equal_error.h).
struct EqualError {
  std::string aov;                // "indirect" or "beauty"
  bool valid = false;             // false: see `note`
  std::string note;               // why not valid
  std::string pbgi_name;
  double pbgi_mse = 0.0;          // as measured (noise floor included)
  double noise_floor = 0.0;       // subtracted before matching
  double pbgi_render_seconds = 0.0, pbgi_total_seconds = 0.0;
  double pbgi_render_cpu_seconds = 0.0, pbgi_total_cpu_seconds = 0.0;
  double path_spp = 0.0;          // interpolated (log-log) samples per pixel
  double path_seconds = 0.0;      // interpolated render time, wall clock
  double path_cpu_seconds = 0.0;  // the same in CPU seconds
  // The target lies outside the sweep's MSE range: extrapolated with
  // MSE ~ 1/spp and time ~ spp from the nearest end.
  bool extrapolated = false;
  double speedup = 0.0;                  // path_seconds / pbgi_render_seconds
  double speedup_including_build = 0.0;  // path_seconds / pbgi_total_seconds
  double speedup_cpu = 0.0;              // path_cpu_seconds / pbgi_render_cpu_seconds
  // For a configuration off the default's curve (another gather method or
  // payload): the render seconds (wall and CPU) of the default's curve at
  // this MSE (equal_error.h, front_seconds_at_error; 0 = outside its range)
  // and the speed-up over it.
  double default_curve_seconds = 0.0, default_curve_cpu_seconds = 0.0;
  double speedup_over_default = 0.0, speedup_over_default_cpu = 0.0;
};

struct BenchResult {
  std::string scene;              // path or source_path of the scene
  std::string scene_hash;
  std::string camera;
  uint32_t width = 0, height = 0;
  uint32_t max_depth = 0;
  uint32_t threads = 0;           // TBB's concurrency during the run
  ReferenceRecord reference;
  std::vector<BuildRecord> builds;
  std::vector<BenchRow> rows;
  EqualError equal_indirect, equal_beauty;
  // Indirect AOV, one per MethodConfig::equal_error_point row: the path
  // tracer's cost at its error and, off the default's curve, the speed-up
  // over that curve.
  std::vector<EqualError> equal_points;
  std::filesystem::path json_file, csv_file, plot_file;  // plot_file empty: no plot
  std::vector<std::string> warnings;
  double wall_seconds = 0.0;      // the whole run
};

}  // namespace pbgi::bench
