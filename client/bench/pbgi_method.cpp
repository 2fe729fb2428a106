#include "client/bench/pbgi_method.h"

#include "server/engine/scene_session.h"
#include "server/render/tile_renderer.h"
#include "storage/format/errors.h"

#include <fmt/format.h>

#include <algorithm>
#include <system_error>

namespace pbgi::bench {
namespace {

namespace fs = std::filesystem;

// A built page set with its own page cache. The page set directory is
// scratch: removed when the build is dropped.
class PbgiBuilt final : public BuiltState {
 public:
  PbgiBuilt(std::shared_ptr<SceneSession> session, std::shared_ptr<storage::PageCache> cache,
            fs::path dir)
      : session_(std::move(session)), cache_(std::move(cache)), dir_(std::move(dir)) {}

  ~PbgiBuilt() override {
    session_.reset();
    std::error_code ec;  // best effort: a leftover is only scratch
    fs::remove_all(dir_, ec);
  }

  // Every page decoded into the cache, so renders measure gathering only.
  void load() override {
    const uint32_t pages = session_->tree->manifest().stats.page_count;
    for (uint32_t id = 0; id < pages; ++id) session_->tree->page(id);
  }

  std::vector<Param> describe() const override {
    const storage::PageSetStats& s = session_->info.tree;
    const storage::CacheCounters c = cache_->counters();
    return {{"surfels", std::to_string(s.surfel_count)},
            {"nodes", std::to_string(s.node_count)},
            {"pages", std::to_string(s.page_count)},
            {"tree_depth", std::to_string(s.max_depth)},
            {"file_bytes", std::to_string(s.file_bytes)},
            {"cache_bytes_held", std::to_string(c.bytes_held)},
            {"cache_evictions", std::to_string(c.evictions)}};
  }

  const SceneSession& session() const { return *session_; }

 private:
  std::shared_ptr<SceneSession> session_;
  std::shared_ptr<storage::PageCache> cache_;
  fs::path dir_;
};

std::string surfel_label(uint64_t n) {
  return n % 1000 == 0 ? fmt::format("{}k", n / 1000) : std::to_string(n);
}

std::unique_ptr<BuiltState> build_pbgi(const BenchInput& input, const PbgiSweep& sweep,
                                       uint64_t target_surfels, const std::string& dir_name) {
  // 1. A fresh directory: a page set left by an earlier run would be reused
  // by open_scene_model and the build time would not be measured.
  const fs::path dir = input.work_dir / dir_name;
  std::error_code ec;
  fs::remove_all(dir, ec);
  fs::create_directories(dir, ec);
  if (ec) throw IoError(fmt::format("cannot create {}: {}", dir.string(), ec.message()));

  // 2. Surfels and page set from a copy of the scene (the session owns it).
  OpenOptions options;
  options.surfels.target_surfels = target_surfels;
  options.surfels.light_samples = sweep.surfel_light_samples;
  options.surfels.seed = sweep.seed;
  EngineContext ctx;
  ctx.cache_dir = dir;
  ctx.cache = std::make_shared<storage::PageCache>(input.page_cache_bytes);
  auto scene = std::make_unique<Scene>(input.scene);
  scene->content_hash = input.scene_hash;
  auto session = open_scene_model(std::move(scene), options, ctx);
  if (session->info.reused_cache)
    throw Error(fmt::format("page set in {} was reused, not built: the build time is wrong",
                            dir.string()));
  return std::make_unique<PbgiBuilt>(std::move(session), ctx.cache, dir);
}

RenderedAovs render_pbgi(const BenchInput& input, const BuiltState* built,
                         const RenderOptions& options) {
  const auto* pbgi = dynamic_cast<const PbgiBuilt*>(built);
  if (!pbgi) throw InvalidArgument("PBGI configuration rendered without its page set");
  const SceneSession& s = pbgi->session();
  const TileRect whole{0, 0, input.width, input.height};
  TileAovs t = render_tile(*s.rays, *s.tree, input.camera, input.width, input.height, whole, options);
  return {std::move(t.beauty), std::move(t.direct), std::move(t.indirect)};
}

template <typename T>
bool contains(const std::vector<T>& v, const T& x) {
  return std::find(v.begin(), v.end(), x) != v.end();
}

}  // namespace

void PbgiSweep::validate() const {
  if (target_surfels.empty() || microbuffer_resolutions.empty() || max_solid_angles.empty())
    throw InvalidArgument("bench: the PBGI sweep needs at least one surfel budget, microbuffer "
                          "resolution and max_solid_angle");
  for (uint64_t n : target_surfels) {
    SurfelOptions s;
    s.target_surfels = n;
    s.light_samples = surfel_light_samples;
    s.validate();
    if (n == 0) throw InvalidArgument("bench: target_surfels must be > 0");
  }
  for (uint32_t mb : microbuffer_resolutions)
    for (float sa : max_solid_angles) {
      GatherOptions g;
      g.microbuffer_resolution = mb;
      g.max_solid_angle = sa;
      g.validate();
    }
  RenderOptions r;
  r.pixel_samples = pixel_samples;
  r.light_samples = light_samples;
  r.validate();
  for (uint32_t px : extra_pixel_samples) {
    r.pixel_samples = px;
    r.validate();
    if (px == pixel_samples || std::count(extra_pixel_samples.begin(), extra_pixel_samples.end(), px) > 1)
      throw InvalidArgument(fmt::format("bench: extra_pixel_samples {} repeats a pixel sample count", px));
  }
  if (!contains(target_surfels, default_target_surfels) ||
      !contains(microbuffer_resolutions, default_microbuffer_resolution) ||
      !contains(max_solid_angles, default_max_solid_angle))
    throw InvalidArgument(fmt::format(
        "bench: the default PBGI configuration (target_surfels {}, microbuffer {}, "
        "max_solid_angle {}) must be part of the sweep",
        default_target_surfels, default_microbuffer_resolution, default_max_solid_angle));
}

namespace {

MethodConfig pbgi_config(const PbgiSweep& sweep, const std::string& build, uint64_t surfels,
                         uint32_t mb, float sa, uint32_t pixel_samples) {
  RenderOptions options;
  options.gather.microbuffer_resolution = mb;
  options.gather.max_solid_angle = sa;
  options.pixel_samples = pixel_samples;
  options.light_samples = sweep.light_samples;
  options.seed = sweep.seed;
  MethodConfig c;
  c.method = "pbgi";
  c.name = fmt::format("{}/mb{}/sa{:g}", build, mb, sa);
  c.series = fmt::format("pbgi s{} mb{}", surfel_label(surfels), mb);
  if (pixel_samples != sweep.pixel_samples) {
    c.name += fmt::format("/px{}", pixel_samples);
    c.series = fmt::format("pbgi s{} mb{} sa{:g} px", surfel_label(surfels), mb, sa);
  }
  c.build = build;
  c.params = {{"target_surfels", std::to_string(surfels)},
              {"microbuffer_resolution", std::to_string(mb)},
              {"max_solid_angle", fmt::format("{:g}", sa)},
              {"pixel_samples", std::to_string(pixel_samples)},
              {"light_samples", std::to_string(sweep.light_samples)}};
  c.is_default = surfels == sweep.default_target_surfels &&
                 mb == sweep.default_microbuffer_resolution &&
                 sa == sweep.default_max_solid_angle && pixel_samples == sweep.pixel_samples;
  c.render = [options](const BenchInput& in, const BuiltState* built) {
    return render_pbgi(in, built, options);
  };
  return c;
}

}  // namespace

MethodPlan pbgi_plan(const PbgiSweep& sweep) {
  sweep.validate();
  MethodPlan plan;
  for (uint64_t surfels : sweep.target_surfels) {
    const std::string build = "pbgi/s" + surfel_label(surfels);
    const std::string dir_name = "pbgi-s" + std::to_string(surfels);
    plan.builds.push_back({build,
                           {{"target_surfels", std::to_string(surfels)}},
                           [sweep, surfels, dir_name](const BenchInput& in) {
                             return build_pbgi(in, sweep, surfels, dir_name);
                           }});
    for (uint32_t mb : sweep.microbuffer_resolutions)
      for (float sa : sweep.max_solid_angles)
        plan.configs.push_back(pbgi_config(sweep, build, surfels, mb, sa, sweep.pixel_samples));
    if (surfels != sweep.default_target_surfels) continue;
    for (uint32_t px : sweep.extra_pixel_samples)
      plan.configs.push_back(pbgi_config(sweep, build, surfels, sweep.default_microbuffer_resolution,
                                         sweep.default_max_solid_angle, px));
  }
  return plan;
}

}  // namespace pbgi::bench
