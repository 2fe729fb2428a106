// `pbgi reference SCENE`: renders the unbiased path-traced reference of a
// USD scene's camera into a multi-layer EXR (the AOVs of path_tracer.h:
// beauty, direct, indirect, indirect1, albedo, ao), optionally with a PNG of
// the beauty through the OCIO display transform.
#include "client/bench/reference_cache.h"
#include "client/cli/command.h"
#include "client/cli/output_paths.h"
#include "client/cli/tool_commands.h"
#include "client/image/exr_image.h"
#include "client/image/png_display.h"
#include "common/errors.h"
#include "server/ingest/usd_ingest.h"
#include "server/reference/path_tracer.h"
#include "server/scene/auto_camera.h"
#include "server/scene/default_lights.h"
#include "server/volumes/fog_field.h"

#include <fmt/format.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <unistd.h>

namespace pbgi::tools {
namespace {

using cli::check_output_file;
using cli::CommandRegistrar;
using cli::tool_command_description;

struct ReferenceArgs {
  std::string scene;
  std::string camera;
  std::string out = "reference.exr";
  ReferenceOptions render;
  FogOptions fog;  // the daemon's defaults unless a flag sets them
  bool png = false;
  bool png_all = false;
  bool half = false;
  bool hide_lights = false;
  bool default_light = false;
  bool quiet = false;
};

// A progress line on stderr: redrawn in place on a terminal, one line per
// quarter otherwise (so logs stay readable).
class ProgressBar {
 public:
  explicit ProgressBar(bool quiet) : quiet_(quiet), tty_(isatty(fileno(stderr)) != 0) {}

  bool operator()(const ReferenceProgress& p) {
    if (quiet_) return true;
    const double f = double(p.spp_done) / double(p.spp_total);
    const double eta = f > 0 ? p.seconds * (1 - f) / f : 0;
    if (tty_) {
      constexpr int kWidth = 30;
      const int filled = int(f * kWidth + 0.5);
      std::fprintf(stderr, "\r[%s%s] %u/%u spp  %.1fs  eta %.1fs ",
                   std::string(filled, '#').c_str(), std::string(kWidth - filled, ' ').c_str(),
                   p.spp_done, p.spp_total, p.seconds, eta);
      if (p.spp_done == p.spp_total) std::fputc('\n', stderr);
    } else if (int(f * 4) > quarter_ || p.spp_done == p.spp_total) {
      quarter_ = int(f * 4);
      std::fprintf(stderr, "reference: %u/%u spp, %.1fs\n", p.spp_done, p.spp_total, p.seconds);
    }
    std::fflush(stderr);
    return true;
  }

 private:
  bool quiet_, tty_;
  int quarter_ = 0;
};

int run(const ReferenceArgs& args) {
  const auto start = std::chrono::steady_clock::now();
  check_output_file(args.out, "--out");  // before minutes of path tracing
  // 1. Scene and camera.
  Scene scene = read_usd_scene(args.scene, IngestOptions{});
  // The daemon's rule (scene_session.cpp): a scene without light gets the
  // default lights if asked, else a warning.
  if (!scene_has_light(scene)) {
    if (args.default_light) add_default_lights(scene);
    else scene.warnings.push_back(no_light_warning());
  }
  for (const std::string& w : scene.warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
  const Camera camera =
      resolve_camera(scene, args.camera, float(args.render.width) / float(args.render.height));
  const double load_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  // 2. Render.
  ReferenceOptions options = args.render;
  options.lights_visible_to_camera = !args.hide_lights;
  RayScene rays(scene);
  // Fog grids attenuate and scatter light as the daemon's do (FogField).
  const auto fog = std::make_shared<FogField>(scene, args.fog);
  if (!fog->empty()) rays.set_medium(fog);
  ProgressBar bar(args.quiet);
  ReferenceStats stats;
  const ReferenceImage result =
      render_reference(rays, camera, options, [&](const ReferenceProgress& p) { return bar(p); },
                       &stats);

  // 3. Write the EXR (with provenance) and the PNG.
  image::ExrImage img = bench::reference_exr(result);
  auto& attrs = img.attributes();
  attrs["pbgi/renderer"] = "reference path tracer";
  attrs["pbgi/scene"] = args.scene;
  attrs["pbgi/scene_hash"] = scene.content_hash;
  attrs["pbgi/camera"] = camera.prim_path;
  attrs["pbgi/spp"] = std::to_string(result.spp);
  attrs["pbgi/seed"] = std::to_string(options.seed);
  attrs["pbgi/max_depth"] = std::to_string(options.max_depth);
  attrs["pbgi/render_seconds"] = fmt::format("{:.3f}", stats.seconds);
  image::ExrWriteOptions write;
  write.pixel_type = args.half ? image::ExrPixelType::Half : image::ExrPixelType::Float;
  image::write_exr(args.out, img, write);
  std::vector<std::string> pngs;
  if (args.png || args.png_all) {
    const std::filesystem::path out(args.out);
    for (const std::string& layer : img.layer_names()) {
      if (!layer.empty() && !args.png_all) continue;
      std::filesystem::path png = out;
      png.replace_extension(layer.empty() ? ".png" : "." + layer + ".png");
      image::write_png(png.string(), img, layer);
      pngs.push_back(png.string());
    }
  }

  std::printf("%s: %ux%u, %u spp, camera %s\n", args.out.c_str(), result.width, result.height,
              result.spp, camera.prim_path.c_str());
  std::printf("load %.3fs, render %.3fs (%.2f Mrays/s, %llu rays)\n", load_seconds, stats.seconds,
              stats.seconds > 0 ? double(stats.rays) / stats.seconds * 1e-6 : 0.0,
              static_cast<unsigned long long>(stats.rays));
  if (stats.nonfinite_samples > 0)
    std::printf("warning: %llu non-finite samples dropped\n",
                static_cast<unsigned long long>(stats.nonfinite_samples));
  for (const std::string& png : pngs) std::printf("%s\n", png.c_str());
  return 0;
}

const CommandRegistrar kRegistrar("reference", [](CLI::App& app, int* exit_code) {
  auto args = std::make_shared<ReferenceArgs>();
  CLI::App* cmd = app.add_subcommand("reference", tool_command_description("reference"));
  cmd->add_option("scene", args->scene, "USD scene file")->required();
  cmd->add_option("--camera,-c", args->camera, "Camera prim path, or auto: the scene framed (default: the only camera; auto without any)");
  cmd->add_option("--out,-o", args->out, "Output EXR")->capture_default_str();
  cmd->add_option("--width", args->render.width, "Image width")->capture_default_str();
  cmd->add_option("--height", args->render.height, "Image height")->capture_default_str();
  cmd->add_option("--spp", args->render.spp, "Samples per pixel")->capture_default_str();
  cmd->add_option("--pass-spp", args->render.pass_spp, "Samples per pixel per progressive pass")
      ->capture_default_str();
  cmd->add_option("--seed", args->render.seed, "Random seed")->capture_default_str();
  cmd->add_option("--max-depth", args->render.max_depth, "Most reflections per path")
      ->capture_default_str();
  cmd->add_option("--rr-depth", args->render.rr_start_depth,
                  "Reflections before Russian roulette starts")
      ->capture_default_str();
  cmd->add_option("--ao-max-distance", args->render.ao_max_distance,
                  "AO occluder distance (0 = unbounded)")
      ->capture_default_str();
  cmd->add_option("--fog-extinction", args->fog.extinction_per_density,
                  "fog grids: extinction per unit density and world unit (sigma_t = density x this)")
      ->capture_default_str();
  cmd->add_option_function<float>(
         "--fog-albedo", [args](float a) { args->fog.albedo = C3f(a); },
         "fog grids: grey single-scattering albedo, 0 = absorbing [0.8]");
  cmd->add_flag("--camera-fog", args->render.fog_on_camera_rays,
                "Fog attenuates and scatters along camera rays too (the daemon's images have none there)");
  cmd->add_flag("--hide-lights", args->hide_lights, "Camera rays do not see area lights");
  cmd->add_flag("--default-light", args->default_light,
                "A scene without any light gets a grey dome and a key light (as pbgid's)");
  cmd->add_flag("--png", args->png, "Also write <out>.png of the beauty (sRGB display)");
  cmd->add_flag("--png-all", args->png_all, "Also write <out>.<aov>.png for every AOV");
  cmd->add_flag("--half", args->half, "Store half floats (smaller, less exact)");
  cmd->add_flag("--quiet,-q", args->quiet, "No progress bar");
  cmd->callback([args, exit_code] { *exit_code = run(*args); });
});

}  // namespace
}  // namespace pbgi::tools
