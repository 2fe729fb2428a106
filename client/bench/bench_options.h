// Options of `pbgi bench`: image, sweep, reference, outputs. One struct
// shared by the CLI flags and the tests; documented defaults give the full
// sweep of docs/benchmarks.md, quick_bench_options() the small CI sweep.
#pragma once

#include "client/bench/path_method.h"
#include "client/bench/pbgi_method.h"

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>

namespace pbgi::bench {

struct BenchOptions {
  // Camera prim path or "auto"; "" = the scene's only camera, auto without any
  // (server/scene/auto_camera.h, resolve_camera).
  std::string camera;
  // Image size in pixels (1..4096 each).
  uint32_t width = 128;
  uint32_t height = 128;

  PbgiSweep pbgi;
  PathSweep path;

  // The converged reference: path traced with this many samples per pixel,
  // path.max_depth reflections and its own seed (independent of the
  // sweep's samples, else the sweep would be compared with itself).
  uint32_t reference_spp = 4096;
  uint64_t reference_seed = 0x5eedf00dull;

  // Where bench.json, bench.csv and bench.png go (created; required).
  std::filesystem::path out_dir;
  // Cached references ("" = <out_dir>/cache): reused by later runs with the
  // same scene hash, camera, size, spp, depth and seed.
  std::filesystem::path cache_dir;
  // Scratch for page sets ("" = <out_dir>/work); emptied after the run.
  // Page sets are always built fresh so that build times are measured.
  std::filesystem::path work_dir;
  // Budget of each build's page cache; the whole page set should fit, or
  // render times include page loads (a warning says so).
  uint64_t page_cache_bytes = 4ull << 30;

  // Also write <out_dir>/images/<config>.exr per configuration and the
  // reference (for looking at the errors).
  bool save_images = false;
  // Run scripts/plot_bench.py to write bench.png.
  bool plot = true;
  // Interpreter with matplotlib ("" = PBGI_PYTHON of this build) and the
  // script ("" = <PBGI_SOURCE_DIR>/scripts/plot_bench.py).
  std::string python;
  std::filesystem::path plot_script;

  // Progress lines (one per build, render and reference); none if empty.
  std::function<void(const std::string&)> log;

  // Throws InvalidArgument naming the field.
  void validate() const;
};

// The small sweep of `pbgi bench --quick` (CI): 64x64, one surfel budget of
// 20k, microbuffers 4 and 8, cut thresholds 0.1 and 0.03, both gather
// methods and payload codecs of the full sweep, the path tracer up to 64 spp,
// a 1024-spp reference.
BenchOptions quick_bench_options();

}  // namespace pbgi::bench
