// The sweep of `pbgi bench` is a list of named method configurations. A
// method (PBGI and factorized PBGI with their payload codecs, the path
// tracer) contributes a MethodPlan: the builds it needs (e.g. one page set
// per surfel budget) and the configurations it renders, each from one build
// or from the scene alone. The runner times builds and renders separately
// and measures every rendered image against the same reference, so a new
// method plugs in by writing one plan function (see pbgi_method.h,
// path_method.h) and listing it in bench_runner.cpp.
//
// Thread-safety: plans are plain values; the runner calls build, load and
// render functions one at a time (each may run TBB tasks inside).
#pragma once

#include "server/scene/ray_scene.h"

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace pbgi::bench {

// What every method renders: the scene, its ray structure, the camera and
// the image size. Read-only during the sweep.
struct BenchInput {
  const Scene& scene;
  const std::string& scene_hash;    // content hash of `scene` (scene_hash.h)
  const RayScene& rays;
  const Camera& camera;
  uint32_t width = 0, height = 0;
  std::filesystem::path work_dir;   // scratch for builds; removed by the runner
  uint64_t page_cache_bytes = 0;    // budget of a build's page cache
};

// The AOVs measured against the reference: pixel-interleaved RGB, row-major,
// y down from the top, width * height * 3 floats each.
struct RenderedAovs {
  std::vector<float> beauty, direct, indirect;
  // Counts the render reports about itself (e.g. gathers_per_pixel),
  // appended to the row's parameters.
  std::vector<std::pair<std::string, std::string>> stats;
};

// A named parameter of a configuration or build (a column of bench.csv).
using Param = std::pair<std::string, std::string>;

// State a build produces and configurations render from (e.g. a page set).
// Destroying it releases its resources (the page set directory).
class BuiltState {
 public:
  virtual ~BuiltState() = default;
  // Brings the build into the state renders run from (e.g. loads every page
  // into the page cache), so that render times measure rendering only. The
  // runner times it apart from the build.
  virtual void load() {}
  // Facts about the result for bench.json (surfel count, bytes, ...).
  virtual std::vector<Param> describe() const { return {}; }
};

struct BuildSpec {
  std::string name;            // unique in the sweep, e.g. "pbgi/s200k"
  std::vector<Param> params;
  std::function<std::unique_ptr<BuiltState>(const BenchInput&)> build;
};

struct MethodConfig {
  std::string method;          // curve family in the plot: "pbgi", "path"
  std::string name;            // unique in the sweep, e.g. "pbgi/s200k/mb8/sa0.03"
  std::string series;          // points drawn as one line, in sweep order
  std::vector<Param> params;
  std::string build;           // BuildSpec::name it renders from; "" = none
  uint32_t spp = 0;            // samples per pixel of a sampling method (0 = n/a)
  // The configuration the equal-error figure is computed for (one per sweep).
  bool is_default = false;
  // Also compare with the path tracer (and, for other methods or payloads
  // than the default's, with the default's curve) at this configuration's
  // error: BenchResult::equal_points.
  bool equal_error_point = false;
  // Part of the default configuration's curve (its method and payload at
  // any gather setting): the curve other methods' speed-up is measured on.
  bool default_curve = false;
  // `built` is the state of `build`, nullptr when build is "". Throws pbgi::Error.
  std::function<RenderedAovs(const BenchInput&, const BuiltState* built)> render;
};

struct MethodPlan {
  std::vector<BuildSpec> builds;
  std::vector<MethodConfig> configs;

  void append(MethodPlan other);
  // Throws InvalidArgument for duplicate names, a configuration naming an
  // unknown build, a missing function, or more than one default.
  void validate() const;
};

}  // namespace pbgi::bench
