#include "tests/stability/stability_harness.h"

#include "client/image/exr_image.h"
#include "common/errors.h"
#include "server/engine/scene_session.h"
#include "server/reference/path_tracer.h"
#include "server/render/tile_renderer.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <system_error>
#include <unistd.h>

namespace pbgi::stability {
namespace {

const Camera& camera_of(const Scene& scene, const std::string& path) {
  const Camera* c = scene.find_camera(path);
  if (!c) throw NotFound(scene.source_path + ": no camera " + path);
  return *c;
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

std::string dump_name(const Scene& scene, const std::string& camera, const char* renderer) {
  std::string name = scene.source_path + camera + "-" + renderer;
  for (char& c : name)
    if (c == '/') c = '-';
  return name;
}

}  // namespace

ScratchDir::ScratchDir(const std::string& name) {
  path_ = std::filesystem::path(PBGI_TEST_BINARY_DIR) / "stability-scratch" /
          (name + "-" + std::to_string(::getpid()));
  std::filesystem::remove_all(path_);
  std::filesystem::create_directories(path_);
}

ScratchDir::~ScratchDir() {
  std::error_code ec;
  std::filesystem::remove_all(path_, ec);
}

PbgiScene::PbgiScene(const Scene& scene, const RenderSettings& s)
    : settings_(s), dir_("pbgi-" + scene.source_path) {
  OpenOptions open;
  open.surfels.target_surfels = s.target_surfels;
  open.surfels.sampler = s.sampler;
  open.bounce.bounces = s.bounces;
  open.tree.air_region_resolution = s.air_region_resolution;
  EngineContext ctx;
  ctx.cache_dir = dir_.path();
  ctx.cache = std::make_shared<storage::PageCache>(1ull << 30);
  const auto t0 = std::chrono::steady_clock::now();
  session_ = open_scene_model(std::make_unique<Scene>(scene), open, ctx);
  std::printf("[ timing   ] %s: PBGI build %.2f s\n", scene.source_path.c_str(), seconds_since(t0));
}

PbgiScene::~PbgiScene() = default;

Aovs PbgiScene::render(const std::string& camera) const {
  const RenderSettings& s = settings_;
  RenderOptions ro;
  ro.gather = s.gather;
  ro.pixel_samples = s.pixel_samples;
  ro.interpolation = s.interpolation;
  const Camera& cam = camera_of(*session_->scene, camera);
  const auto t0 = std::chrono::steady_clock::now();
  TileAovs t = render_tile(*session_->rays, *session_->tree, cam, s.width, s.height, {0, 0, s.width, s.height}, ro);
  std::printf("[ timing   ] %s%s: PBGI render %.2f s\n", session_->scene->source_path.c_str(),
              camera.c_str(), seconds_since(t0));
  if (ro.interpolation.mode == InterpolationMode::kOff) {
    RenderOptions interpolated = ro;
    interpolated.interpolation = InterpolationOptions{};
    const TileAovs i = render_tile(*session_->rays, *session_->tree, cam, s.width, s.height,
                                   {0, 0, s.width, s.height}, interpolated);
    const double err = relative_rmse(i.indirect, t.indirect);
    std::printf("[ measured ] %s%s: interpolated vs per-sample indirect %.4g (bound %g)\n",
                session_->scene->source_path.c_str(), camera.c_str(), err, s.interpolation_bound);
    EXPECT_LE(err, s.interpolation_bound) << session_->scene->source_path << camera;
  }
  Aovs out{std::move(t.beauty), std::move(t.direct), std::move(t.indirect)};
  dump_aovs(dump_name(*session_->scene, camera, "pbgi"), out, s);
  return out;
}

Aovs render_pbgi(const Scene& scene, const std::string& camera, const RenderSettings& s) {
  return PbgiScene(scene, s).render(camera);
}

Aovs render_path(const Scene& scene, const std::string& camera, const RenderSettings& s) {
  const RayScene rays(scene);
  ReferenceOptions o;
  o.width = s.width;
  o.height = s.height;
  o.spp = s.reference_spp;
  o.pass_spp = s.reference_spp;
  o.max_depth = s.reference_max_depth;
  o.seed = s.reference_seed;
  const auto t0 = std::chrono::steady_clock::now();
  ReferenceImage r = render_reference(rays, camera_of(scene, camera), o);
  std::printf("[ timing   ] %s%s: reference %u spp %.2f s\n", scene.source_path.c_str(),
              camera.c_str(), o.spp, seconds_since(t0));
  Aovs out{std::move(r.beauty), std::move(r.direct), std::move(r.indirect)};
  dump_aovs(dump_name(scene, camera, "reference"), out, s);
  return out;
}

void dump_aovs(const std::string& name, const Aovs& aovs, const RenderSettings& s) {
  const char* dir = std::getenv("PBGI_STABILITY_DUMP");
  if (!dir || !*dir) return;
  std::filesystem::create_directories(dir);
  image::ExrImage img(s.width, s.height);
  img.set_rgb("", aovs.beauty);
  img.set_rgb("direct", aovs.direct);
  img.set_rgb("indirect", aovs.indirect);
  image::write_exr((std::filesystem::path(dir) / (name + ".exr")).string(), img);
}

double relative_rmse(const std::vector<float>& t, const std::vector<float>& r) {
  if (t.size() != r.size()) throw InvalidArgument("relative_rmse: sizes differ");
  double num = 0, den = 0;
  for (size_t i = 0; i < t.size(); ++i) {
    const double d = double(t[i]) - double(r[i]);
    num += d * d;
    den += double(r[i]) * double(r[i]);
  }
  return den > 0 ? std::sqrt(num / den) : (num > 0 ? INFINITY : 0.0);
}

double mean_value(const std::vector<float>& v) {
  double sum = 0;
  for (float x : v) sum += x;
  return v.empty() ? 0.0 : sum / double(v.size());
}

bool all_finite(const std::vector<float>& v) {
  for (float x : v)
    if (!std::isfinite(x)) return false;
  return true;
}

}  // namespace pbgi::stability
