// Renders a stability scene both ways at low resolution (PBGI through the
// in-process pipeline open_scene_model + render_tile, and the reference
// path tracer) and measures the difference.
#pragma once

#include "server/gather/gather_options.h"
#include "server/render/gather_lattice.h"
#include "server/scene/scene.h"
#include "server/surfels/surfel_options.h"
#include "storage/tree/build_options.h"

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace pbgi {
struct SceneSession;
}

namespace pbgi::stability {

struct RenderSettings {
  uint32_t width = 32;
  uint32_t height = 32;
  uint64_t target_surfels = 20000;
  // The surfel sampler (the daemon's default, uniform, unless a case needs
  // the Poisson sampler's guarantees).
  SurfelSampler sampler = SurfelSampler::kUniform;
  GatherOptions gather;           // the library defaults
  // PBGI camera rays per pixel: 4 stratified samples approach the box
  // filter the path tracer integrates, so edges do not count as error.
  uint32_t pixel_samples = 4;
  uint32_t reference_spp = 1024;
  // One diffuse bounce (PBGI's transport): the reference's indirect AOV is
  // then exactly what PBGI's gather estimates.
  uint32_t reference_max_depth = 2;
  uint64_t reference_seed = 7;
  // Light bounces the PBGI build puts into the surfels (BounceOptions).
  uint32_t bounces = 1;
  // The build's air regions (tree::BuildOptions; 0 = off).
  uint32_t air_region_resolution = tree::BuildOptions{}.air_region_resolution;
  // The bounds of the cases are those of one gather per camera sample (the
  // gather's own stability). Every render is also made with the
  // interpolating renderer (the product's default), whose indirect layer
  // must stay within kInterpolationBound (relative RMSE) of it.
  InterpolationOptions interpolation{InterpolationMode::kOff};
  double interpolation_bound = 0.06;  // kInterpolationBound unless a case says why
};

// Interpolated against per-sample gathers, indirect relative RMSE, on every
// case of the suite unless it says why not (measured: 0.042-0.055 at
// 32 x 32, where an 8-pixel cell is a quarter of the image).
inline constexpr double kInterpolationBound = 0.06;

// Pixel-interleaved RGB AOVs, row-major.
struct Aovs {
  std::vector<float> beauty, direct, indirect;
};

// A directory removed (recursively) when the object dies.
class ScratchDir {
 public:
  explicit ScratchDir(const std::string& name);
  ~ScratchDir();
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

// A scene's PBGI page set, built once (in a scratch directory), rendered
// from any of its cameras.
class PbgiScene {
 public:
  PbgiScene(const Scene& scene, const RenderSettings& settings);
  ~PbgiScene();
  Aovs render(const std::string& camera) const;

 private:
  RenderSettings settings_;
  ScratchDir dir_;
  std::shared_ptr<SceneSession> session_;
};

Aovs render_pbgi(const Scene& scene, const std::string& camera, const RenderSettings& settings);
Aovs render_path(const Scene& scene, const std::string& camera, const RenderSettings& settings);

// If $PBGI_STABILITY_DUMP names a directory, writes <dir>/<name>.exr with
// the AOVs (beauty, direct, indirect) for looking at a failing case.
void dump_aovs(const std::string& name, const Aovs& aovs, const RenderSettings& settings);

// sqrt(sum (t - r)^2 / sum r^2): the RMSE relative to the reference's RMS.
double relative_rmse(const std::vector<float>& test, const std::vector<float>& reference);
double mean_value(const std::vector<float>& v);
bool all_finite(const std::vector<float>& v);

}  // namespace pbgi::stability
