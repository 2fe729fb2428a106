// `pbgi bench SCENE`: speed against error. Builds PBGI page sets and renders
// a sweep of PBGI and factorized-PBGI settings and payload codecs, and of
// path-tracer sample counts in this
// process, measures each against a converged (cached) reference, writes
// bench.json / bench.csv / bench.png to --out-dir and prints a summary with
// the path tracer's cost at PBGI's error. See docs/benchmarks.md.
#include "client/bench/bench_report.h"
#include "client/bench/bench_runner.h"
#include "client/cli/command.h"
#include "client/cli/tool_commands.h"
#include "common/errors.h"
#include "server/render/gather_lattice.h"

#include <algorithm>
#include <cstdio>
#include <memory>
#include <optional>

namespace pbgi::tools {
namespace {

using cli::CommandRegistrar;
using cli::tool_command_description;

struct BenchArgs {
  std::string scene;
  std::string camera;
  std::string out_dir = "bench-out";
  std::string cache_dir;
  std::optional<uint32_t> width, height, reference_spp, max_spp, max_depth;
  std::vector<uint64_t> surfels;
  std::vector<uint32_t> microbuffers;
  std::vector<float> solid_angles;
  std::optional<std::vector<uint32_t>> extra_pixel_samples;
  std::vector<std::string> methods;
  std::vector<std::string> payloads;
  std::optional<uint32_t> clusters;
  std::optional<float> epsilon;
  std::optional<uint32_t> glossy_max_resolution;
  std::optional<float> glossy_radiance_weight;
  std::optional<bool> ray_depth_caps;
  std::optional<uint32_t> bounces;
  std::optional<bool> bounce_splatting;
  std::optional<float> bounce_view_solid_angle;
  std::optional<uint32_t> bounce_receiver_stride, bounce_microbuffer_resolution;
  std::optional<float> bounce_max_solid_angle;
  std::optional<uint32_t> pixel_samples;
  std::optional<uint32_t> edge_samples;
  std::vector<std::string> interpolations;
  std::vector<float> tolerances;
  std::optional<uint32_t> spacing;
  bool quick = false;
  bool images = false;
  bool no_plot = false;
  bool quiet = false;
};

int run(const BenchArgs& args) {
  // 1. Options: the full or quick sweep, then the flags given.
  bench::BenchOptions o = args.quick ? bench::quick_bench_options() : bench::BenchOptions{};
  o.camera = args.camera;
  o.out_dir = args.out_dir;
  o.cache_dir = args.cache_dir;
  if (args.width) o.width = *args.width;
  if (args.height) o.height = *args.height;
  if (args.reference_spp) o.reference_spp = *args.reference_spp;
  if (args.max_spp) o.path.max_spp = *args.max_spp;
  if (args.max_depth) o.path.max_depth = *args.max_depth;
  // A swept list given on the command line replaces the preset's; its first
  // value becomes the default unless the preset's default is in it.
  auto pick_default = [](const auto& list, auto* def) {
    if (!list.empty() && std::find(list.begin(), list.end(), *def) == list.end()) *def = list.front();
  };
  if (!args.surfels.empty()) o.pbgi.target_surfels = args.surfels;
  if (!args.microbuffers.empty()) o.pbgi.microbuffer_resolutions = args.microbuffers;
  if (!args.solid_angles.empty()) o.pbgi.max_solid_angles = args.solid_angles;
  if (!args.methods.empty()) {
    o.pbgi.methods.clear();
    for (const std::string& m : args.methods) o.pbgi.methods.push_back(bench::parse_gather_method(m));
  }
  if (!args.payloads.empty()) {
    o.pbgi.payloads.clear();
    for (const std::string& p : args.payloads) o.pbgi.payloads.push_back(bench::parse_payload_spec(p));
  }
  if (args.clusters) o.pbgi.fpbgi_clusters = *args.clusters;
  if (args.epsilon) o.pbgi.fpbgi_epsilon = *args.epsilon;
  if (args.glossy_max_resolution) o.pbgi.glossy_max_resolution = *args.glossy_max_resolution;
  if (args.glossy_radiance_weight) o.pbgi.glossy_radiance_weight = *args.glossy_radiance_weight;
  if (args.ray_depth_caps) o.pbgi.ray_depth_caps = *args.ray_depth_caps;
  if (args.bounces) o.pbgi.bounce.bounces = *args.bounces;
  if (args.bounce_splatting) o.pbgi.bounce.splatting = *args.bounce_splatting;
  if (args.bounce_view_solid_angle) o.pbgi.bounce.view_solid_angle = *args.bounce_view_solid_angle;
  if (args.bounce_receiver_stride) o.pbgi.bounce.receiver_stride = *args.bounce_receiver_stride;
  if (args.bounce_microbuffer_resolution)
    o.pbgi.bounce.gather.microbuffer_resolution = *args.bounce_microbuffer_resolution;
  if (args.bounce_max_solid_angle) o.pbgi.bounce.gather.max_solid_angle = *args.bounce_max_solid_angle;
  pick_default(o.pbgi.methods, &o.pbgi.default_method);
  pick_default(o.pbgi.target_surfels, &o.pbgi.default_target_surfels);
  pick_default(o.pbgi.microbuffer_resolutions, &o.pbgi.default_microbuffer_resolution);
  pick_default(o.pbgi.max_solid_angles, &o.pbgi.default_max_solid_angle);
  if (args.extra_pixel_samples) {
    o.pbgi.extra_pixel_samples.clear();
    for (uint32_t px : *args.extra_pixel_samples)
      if (px != 0) o.pbgi.extra_pixel_samples.push_back(px);
  }
  if (args.pixel_samples) o.pbgi.pixel_samples = *args.pixel_samples;
  if (args.edge_samples) o.pbgi.edge_samples = *args.edge_samples;
  if (!args.interpolations.empty() || !args.tolerances.empty()) {
    // Each mode; "auto" once per tolerance (the library default if none given).
    const std::vector<std::string> modes =
        args.interpolations.empty() ? std::vector<std::string>{"auto"} : args.interpolations;
    const std::vector<float> tolerances =
        args.tolerances.empty() ? std::vector<float>{InterpolationOptions{}.tolerance} : args.tolerances;
    o.pbgi.interpolations.clear();
    for (const std::string& m : modes) {
      const std::optional<InterpolationMode> mode = parse_interpolation_mode(m);
      if (!mode) throw InvalidArgument("bench: --interpolation '" + m + "': expected off or auto");
      InterpolationOptions i;
      i.mode = *mode;
      if (i.mode == InterpolationMode::kOff) {
        o.pbgi.interpolations.push_back(i);
        continue;
      }
      for (float t : tolerances) {
        i.tolerance = t;
        o.pbgi.interpolations.push_back(i);
      }
    }
  }
  if (args.spacing)
    for (InterpolationOptions& i : o.pbgi.interpolations) i.spacing = *args.spacing;
  o.save_images = args.images;
  o.plot = !args.no_plot;
  if (!args.quiet) o.log = [](const std::string& line) { std::fprintf(stderr, "%s\n", line.c_str()); };

  // 2. The sweep.
  const bench::BenchResult r = bench::run_bench_usd(args.scene, o);

  // 3. Summary and outputs.
  std::printf("%s\n", bench::bench_summary(r).c_str());
  std::printf("wrote %s\n      %s\n", r.json_file.c_str(), r.csv_file.c_str());
  if (!r.plot_file.empty()) std::printf("      %s\n", r.plot_file.c_str());
  std::printf("total %.1f s\n", r.wall_seconds);
  return 0;
}

const CommandRegistrar kRegistrar("bench", [](CLI::App& app, int* exit_code) {
  auto args = std::make_shared<BenchArgs>();
  CLI::App* cmd = app.add_subcommand("bench", tool_command_description("bench"));
  cmd->add_option("scene", args->scene, "USD scene file")->required();
  cmd->add_option("--camera,-c", args->camera, "Camera prim path, or auto: the scene framed (default: the only camera; auto without any)");
  cmd->add_option("--out-dir,-o", args->out_dir, "Directory for bench.json/.csv/.png")
      ->capture_default_str();
  cmd->add_option("--cache-dir", args->cache_dir,
                  "Directory of cached references (default: <out-dir>/cache)");
  cmd->add_option("--width", args->width, "Image width (default 128; --quick: 64)");
  cmd->add_option("--height", args->height, "Image height (default 128; --quick: 64)");
  cmd->add_option("--reference-spp", args->reference_spp,
                  "Samples per pixel of the reference (default 4096; --quick: 1024)");
  cmd->add_option("--max-spp", args->max_spp,
                  "Largest path-tracer sample count of the sweep (default 256; --quick: 64)");
  cmd->add_option("--max-depth", args->max_depth,
                  "Reflections per path of the path tracer and reference (default 2: the one "
                  "diffuse bounce PBGI computes)");
  cmd->add_option("--surfels", args->surfels, "Surfel budgets to sweep (default 50000 200000)")
      ->delimiter(',');
  cmd->add_option("--microbuffer", args->microbuffers, "Microbuffer resolutions (default 4,8,16)")
      ->delimiter(',');
  cmd->add_option("--solid-angle", args->solid_angles,
                  "Cut thresholds max_solid_angle (default 0.3,0.1,0.03,0.01)")
      ->delimiter(',');
  cmd->add_option("--extra-pixel-samples", args->extra_pixel_samples,
                  "Extra renders of the default PBGI configuration with this many camera rays "
                  "per pixel (default 16; 0 = none)")
      ->delimiter(',');
  cmd->add_option("--methods", args->methods,
                  "Gather methods, each over every PBGI setting: pbgi, fpbgi (default pbgi,fpbgi)")
      ->delimiter(',');
  cmd->add_option("--payloads", args->payloads,
                  "Payload codecs: derived, float32-sh, kmeans-sh[:LUT_ENTRIES]. The first gets "
                  "the full sweep, the others a page set at the default surfel budget rendered "
                  "at each microbuffer (default derived,kmeans-sh:1024)")
      ->delimiter(',');
  cmd->add_option("--clusters", args->clusters, "FPBGI clusters per 1024 receivers (default 100)");
  cmd->add_option("--pixel-samples", args->pixel_samples,
                  "Camera rays per pixel of every PBGI render (default 4)");
  cmd->add_option("--edge-samples", args->edge_samples,
                  "Camera rays of a pixel on a light's silhouette, interpolation auto (default 256; 0 = none)");
  cmd->add_option("--interpolation", args->interpolations,
                  "Gather interpolation modes to sweep: off (a gather per camera sample), auto "
                  "(adaptive lattice); the first is the default's (default auto)")
      ->delimiter(',');
  cmd->add_option("--interpolation-spacing", args->spacing,
                  "Coarsest interpolation cell in pixels, a power of two (default 8)");
  cmd->add_option("--tolerance", args->tolerances,
                  "Interpolation tolerances to sweep with auto (default 0.1)")
      ->delimiter(',');
  cmd->add_option("--epsilon", args->epsilon,
                  "FPBGI far/near split (default 0 = auto, 0.4 / microbuffer resolution)");
  cmd->add_option("--glossy-max-res", args->glossy_max_resolution,
                  "Glossy receivers' finest lobe microbuffer, 4..64 (default 32; at or below the "
                  "microbuffer resolution: the fixed buffer)");
  cmd->add_option("--glossy-radiance-weight", args->glossy_radiance_weight,
                  "Glossy receivers: share of the lobe's refinement that follows incoming radiance, "
                  "0..1 (default 0.5)")
      ->check(CLI::Range(0.f, 1.f));
  cmd->add_option("--ray-depth-caps", args->ray_depth_caps,
                  "Ray-traced depth caps of the microbuffer for every render (true/false, default false)");
  cmd->add_option("--bounces", args->bounces,
                  "Light bounces every build puts into the surfels (1..4, default 1); compare with "
                  "--max-depth bounces + 1");
  cmd->add_option("--bounce-splatting", args->bounce_splatting,
                  "Bounce gathers: view-tree splatting (true/false, default false)");
  cmd->add_option("--bounce-view-solid-angle", args->bounce_view_solid_angle,
                  "Bounce splatting: view solid angle in sr (default 0 = auto)");
  cmd->add_option("--bounce-receiver-stride", args->bounce_receiver_stride,
                  "Bounce gathers: one surfel in this many gathered, the others interpolated (1 = all)");
  cmd->add_option("--bounce-mb-res", args->bounce_microbuffer_resolution,
                  "Bounce gathers: microbuffer resolution (4..32)");
  cmd->add_option("--bounce-solid-angle", args->bounce_max_solid_angle,
                  "Bounce gathers: cut threshold max_solid_angle in sr");
  cmd->add_flag("--quick", args->quick, "Small sweep for CI (64x64, 20k surfels, 4 settings per gather method)");
  cmd->add_flag("--images", args->images, "Also write <out-dir>/images/<config>.exr");
  cmd->add_flag("--no-plot", args->no_plot, "Do not run scripts/plot_bench.py");
  cmd->add_flag("--quiet,-q", args->quiet, "No progress lines");
  cmd->callback([args, exit_code] { *exit_code = run(*args); });
});

}  // namespace
}  // namespace pbgi::tools
