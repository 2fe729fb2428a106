// `pbgi bench`: speed against error, in one process and one run.
//
//   1. The scene's ray structure and content hash; the camera.
//   2. The converged reference (path traced; cached on disk by key).
//   3. Every build of the sweep (timed), each followed by the renders of
//      its configurations (timed apart), each measured against the
//      reference on the indirect and beauty AOVs.
//   4. The configurations without a build (the path tracer at 1..N spp).
//   5. Pareto flags and the equal-error figure: the path tracer's spp and
//      time at the MSE of PBGI's default configuration, and the speed-up.
//   6. bench.json, bench.csv, and bench.png through scripts/plot_bench.py.
//
// Both renderers run in the caller's TBB arena (all cores by default), one
// render at a time, so times compare like for like. What the error is
// measured on, and why the path tracer and reference are limited to
// BenchOptions::path.max_depth reflections, is in docs/benchmarks.md.
//
// Thread-safety: run one bench at a time per out_dir; the functions are
// otherwise reentrant.
#pragma once

#include "client/bench/bench_options.h"
#include "client/bench/bench_result.h"

#include <filesystem>

namespace pbgi::bench {

// Every method of the sweep (PBGI, the path tracer), in run order.
MethodPlan bench_plan(const BenchOptions& options);

// Runs the sweep on an in-memory scene (its source_path names it in the
// outputs). Throws InvalidArgument for bad options, NotFound for a missing
// camera, IoError for unwritable outputs, and whatever a render throws.
BenchResult run_bench(const Scene& scene, const BenchOptions& options);

// Reads the USD scene (with options.python if set) and runs run_bench.
// Throws SceneError naming the file if it cannot be read.
BenchResult run_bench_usd(const std::filesystem::path& usd_path, const BenchOptions& options);

}  // namespace pbgi::bench
