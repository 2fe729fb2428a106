#include "client/bench/pbgi_method.h"

#include "common/errors.h"
#include "server/engine/scene_session.h"
#include "server/render/tile_renderer.h"
#include "server/scene/auto_camera.h"

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
                                       uint64_t target_surfels, const PayloadSpec& payload,
                                       const std::string& dir_name) {
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
  options.tree.payload_codec = payload.codec;
  options.tree.lut_entries = payload.lut_entries;
  options.bounce = sweep.bounce;
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
  // The session renders in its scene-local frame (open_scene_model rebases
  // the scene, server/scene/render_origin.h): the camera must be the
  // session's copy, moved with the geometry, not the world-space one.
  // (The auto camera is framed again, on the session's bounds.)
  const Camera camera =
      resolve_camera(*s.scene, input.camera.prim_path, float(input.width) / float(input.height));
  const TileRect whole{0, 0, input.width, input.height};
  GatherCounters counters;
  TileAovs t = render_tile(*s.rays, *s.tree, camera, input.width, input.height, whole, options, &counters);
  const double pixels = double(input.width) * input.height;
  return {std::move(t.beauty), std::move(t.direct), std::move(t.indirect),
          {{"gathers_per_pixel", fmt::format("{:.4g}", double(counters.receivers) / pixels)},
           {"camera_samples_per_pixel", fmt::format("{:g}", double(t.camera_samples) / pixels)}}};
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
  r.edge_samples = edge_samples;
  r.light_samples = light_samples;
  r.validate();
  if (interpolations.empty()) throw InvalidArgument("bench: the PBGI sweep needs at least one interpolation setting");
  for (const InterpolationOptions& i : interpolations) i.validate();
  for (uint32_t px : extra_pixel_samples) {
    r.pixel_samples = px;
    r.validate();
    if (px == pixel_samples || std::count(extra_pixel_samples.begin(), extra_pixel_samples.end(), px) > 1)
      throw InvalidArgument(fmt::format("bench: extra_pixel_samples {} repeats a pixel sample count", px));
  }
  if (methods.empty() || payloads.empty())
    throw InvalidArgument("bench: the PBGI sweep needs at least one gather method and payload");
  for (size_t i = 0; i < methods.size(); ++i)
    if (std::count(methods.begin(), methods.end(), methods[i]) > 1)
      throw InvalidArgument("bench: gather method " + gather_method_name(methods[i]) + " repeated");
  for (const PayloadSpec& p : payloads) {
    p.validate();
    if (std::count(payloads.begin(), payloads.end(), p) > 1)
      throw InvalidArgument("bench: payload " + p.label() + " repeated");
  }
  GatherOptions f;
  f.method = GatherMethod::kFpbgi;
  f.clusters = fpbgi_clusters;
  f.epsilon = fpbgi_epsilon;
  f.glossy_max_resolution = glossy_max_resolution;
  f.glossy_radiance_weight = glossy_radiance_weight;
  f.validate();
  bounce.validate();
  if (!contains(methods, default_method))
    throw InvalidArgument("bench: the default gather method " + gather_method_name(default_method) +
                          " must be part of the sweep");
  if (!contains(target_surfels, default_target_surfels) ||
      !contains(microbuffer_resolutions, default_microbuffer_resolution) ||
      !contains(max_solid_angles, default_max_solid_angle))
    throw InvalidArgument(fmt::format(
        "bench: the default PBGI configuration (target_surfels {}, microbuffer {}, "
        "max_solid_angle {}) must be part of the sweep",
        default_target_surfels, default_microbuffer_resolution, default_max_solid_angle));
}

namespace {

// Names carry the payload codec unless it is the library default (derived),
// so that a plain PBGI sweep keeps its names.
std::string payload_suffix(const PayloadSpec& p) {
  return p.codec == tree::PayloadCodecOption::kDerived ? "" : fmt::format("/{}", p.label());
}

// One gather setting of one page set. `main_payload`: the sweep's first
// payload, which gets the full sweep.
struct ConfigKey {
  GatherMethod method;
  uint64_t surfels;
  const PayloadSpec& payload;
  bool main_payload;
  uint32_t mb;
  float sa;
  uint32_t pixel_samples;
  size_t interpolation = 0;  // index in sweep.interpolations
};

// "" for the sweep's first interpolation setting (so that a sweep of one
// keeps its names), else "/interp-off" or "/tol<t>".
std::string interpolation_suffix(const PbgiSweep& sweep, size_t i) {
  if (sweep.interpolations.size() == 1) return "";
  const InterpolationOptions& o = sweep.interpolations[i];
  return o.mode == InterpolationMode::kOff ? "/interp-off" : fmt::format("/tol{:g}", o.tolerance);
}

MethodConfig pbgi_config(const PbgiSweep& sweep, const std::string& build, const ConfigKey& k) {
  RenderOptions options;
  options.gather.method = k.method;
  options.gather.microbuffer_resolution = k.mb;
  options.gather.max_solid_angle = k.sa;
  options.gather.clusters = sweep.fpbgi_clusters;
  options.gather.epsilon = sweep.fpbgi_epsilon;
  options.gather.glossy_max_resolution = sweep.glossy_max_resolution;
  options.gather.glossy_radiance_weight = sweep.glossy_radiance_weight;
  options.gather.ray_depth_caps = sweep.ray_depth_caps;
  options.pixel_samples = k.pixel_samples;
  options.edge_samples = sweep.edge_samples;
  options.light_samples = sweep.light_samples;
  options.seed = sweep.seed;
  options.interpolation = sweep.interpolations[k.interpolation];
  const std::string method = gather_method_name(k.method);
  const std::string payload = payload_suffix(k.payload) + interpolation_suffix(sweep, k.interpolation);
  MethodConfig c;
  c.method = method;
  c.name = fmt::format("{}/s{}{}/mb{}/sa{:g}", method, surfel_label(k.surfels), payload, k.mb, k.sa);
  // Main payload: a curve over the cut threshold per microbuffer; another
  // payload, or a sweep of one cut: a curve over the microbuffer resolution.
  c.series = k.main_payload && sweep.max_solid_angles.size() > 1
                 ? fmt::format("{} s{}{} mb{}", method, surfel_label(k.surfels), payload, k.mb)
                 : fmt::format("{} s{} {}{}", method, surfel_label(k.surfels), k.payload.label(),
                               interpolation_suffix(sweep, k.interpolation));
  if (k.pixel_samples != sweep.pixel_samples) {
    c.name += fmt::format("/px{}", k.pixel_samples);
    c.series = fmt::format("{} s{}{} mb{} sa{:g} px", method, surfel_label(k.surfels), payload, k.mb,
                           k.sa);
  }
  c.build = build;
  c.params = {{"gather_method", method},
              {"target_surfels", std::to_string(k.surfels)},
              {"payload_codec", k.payload.label()},
              {"microbuffer_resolution", std::to_string(k.mb)},
              {"max_solid_angle", fmt::format("{:g}", k.sa)},
              {"pixel_samples", std::to_string(k.pixel_samples)},
              {"edge_samples", std::to_string(sweep.edge_samples)},
              {"light_samples", std::to_string(sweep.light_samples)},
              {"glossy_max_resolution", std::to_string(sweep.glossy_max_resolution)},
              {"glossy_radiance_weight", fmt::format("{:g}", sweep.glossy_radiance_weight)},
              {"ray_depth_caps", sweep.ray_depth_caps ? "true" : "false"},
              {"interpolation", interpolation_mode_name(options.interpolation.mode)},
              {"interpolation_tolerance", fmt::format("{:g}", options.interpolation.tolerance)},
              {"interpolation_spacing", std::to_string(options.interpolation.spacing)}};
  if (k.method == GatherMethod::kFpbgi) {
    c.params.push_back({"clusters", std::to_string(options.gather.clusters)});
    c.params.push_back({"epsilon", fmt::format("{:g}", options.gather.effective_epsilon())});
  }
  const bool default_point = k.surfels == sweep.default_target_surfels &&
                             k.sa == sweep.default_max_solid_angle &&
                             k.pixel_samples == sweep.pixel_samples;
  c.is_default = default_point && k.interpolation == 0 && k.main_payload && k.method == sweep.default_method &&
                 k.mb == sweep.default_microbuffer_resolution;
  c.equal_error_point = default_point;
  c.default_curve = k.interpolation == 0 && k.main_payload && k.method == sweep.default_method &&
                    k.surfels == sweep.default_target_surfels && k.pixel_samples == sweep.pixel_samples;
  c.render = [options](const BenchInput& in, const BuiltState* built) {
    return render_pbgi(in, built, options);
  };
  return c;
}

BuildSpec pbgi_build(const PbgiSweep& sweep, uint64_t surfels, const PayloadSpec& codec,
                     std::string* name) {
  *name = "pbgi/s" + surfel_label(surfels) + payload_suffix(codec);
  std::string dir_name = "pbgi-s" + std::to_string(surfels) + "-" + codec.label();
  std::replace(dir_name.begin(), dir_name.end(), ':', '-');
  std::vector<Param> params{{"target_surfels", std::to_string(surfels)},
                            {"payload_codec", codec.label()}};
  if (sweep.bounce.bounces > 1) {
    params.push_back({"bounces", std::to_string(sweep.bounce.bounces)});
    params.push_back({"bounce_splatting", sweep.bounce.splatting ? "true" : "false"});
    params.push_back({"bounce_view_solid_angle", fmt::format("{:g}", sweep.bounce.effective_view_solid_angle())});
    params.push_back({"bounce_receiver_stride", std::to_string(sweep.bounce.receiver_stride)});
    params.push_back({"bounce_microbuffer_resolution", std::to_string(sweep.bounce.gather.microbuffer_resolution)});
    params.push_back({"bounce_max_solid_angle", fmt::format("{:g}", sweep.bounce.gather.max_solid_angle)});
  }
  return {*name, std::move(params),
          [sweep, surfels, codec, dir_name](const BenchInput& in) {
            return build_pbgi(in, sweep, surfels, codec, dir_name);
          }};
}

}  // namespace

std::string gather_method_name(GatherMethod method) { return std::string(options::enum_name(method)); }

GatherMethod parse_gather_method(const std::string& name) {
  if (const auto method = options::parse_enum<GatherMethod>(name)) return *method;
  throw InvalidArgument("bench: gather method '" + name + "': expected " +
                        options::enum_name_list<GatherMethod>(" or "));
}

MethodPlan pbgi_plan(const PbgiSweep& sweep) {
  sweep.validate();
  MethodPlan plan;
  std::string build;
  // 1. The main payload: every surfel budget, method, microbuffer and cut;
  // the antialiased extras of the default configuration.
  for (uint64_t surfels : sweep.target_surfels) {
    const PayloadSpec& payload = sweep.payloads.front();
    plan.builds.push_back(pbgi_build(sweep, surfels, payload, &build));
    for (size_t interp = 0; interp < sweep.interpolations.size(); ++interp)
      for (GatherMethod m : sweep.methods)
        for (uint32_t mb : sweep.microbuffer_resolutions)
          for (float sa : sweep.max_solid_angles)
            plan.configs.push_back(
                pbgi_config(sweep, build, {m, surfels, payload, true, mb, sa, sweep.pixel_samples, interp}));
    if (surfels != sweep.default_target_surfels) continue;
    for (uint32_t px : sweep.extra_pixel_samples)
      plan.configs.push_back(pbgi_config(sweep, build,
                                         {sweep.default_method, surfels, payload, true,
                                          sweep.default_microbuffer_resolution,
                                          sweep.default_max_solid_angle, px}));
  }
  // 2. Every other payload at the default budget and cut: each method over
  // the microbuffer resolutions.
  for (size_t i = 1; i < sweep.payloads.size(); ++i) {
    const PayloadSpec& payload = sweep.payloads[i];
    const uint64_t surfels = sweep.default_target_surfels;
    plan.builds.push_back(pbgi_build(sweep, surfels, payload, &build));
    for (GatherMethod m : sweep.methods)
      for (uint32_t mb : sweep.microbuffer_resolutions)
        plan.configs.push_back(pbgi_config(
            sweep, build,
            {m, surfels, payload, false, mb, sweep.default_max_solid_angle, sweep.pixel_samples}));
  }
  return plan;
}

}  // namespace pbgi::bench
