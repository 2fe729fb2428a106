// `pbgi render SCENE`: renders a camera's image through a running pbgid,
// tile by tile with several requests in flight, and writes the AOVs as a
// multi-layer EXR plus a display PNG of the beauty (through OCIO).
#include "client/cli/command.h"
#include "client/image/exr_image.h"
#include "client/image/png_display.h"
#include "client/lib/frame_renderer.h"
#include "client/lib/pbgi_client.h"
#include "storage/format/errors.h"

#include <fmt/format.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <unistd.h>

namespace pbgi::cli {
namespace {

using Clock = std::chrono::steady_clock;

struct RenderArgs {
  std::string server;
  std::string scene;
  std::string camera;
  uint32_t width = 512, height = 512, tile = 32;
  unsigned jobs = 4;
  std::string out = "render.exr";
  std::string png;            // "" = out with .png
  bool no_png = false;
  float exposure = 0.f;
  bool half = false;
  bool quiet = false;
  double tile_deadline = 300;  // seconds per RenderTile call
  // 0 = the daemon's default.
  uint32_t mb_res = 0, light_samples = 0, pixel_samples = 0;
  float max_solid_angle = 0.f, ao_max_distance = 0.f;
  std::string method;         // "" = the daemon's default
  uint32_t clusters = 0;
  float epsilon = 0.f, hdr_refine = 0.f;
  uint64_t target_surfels = 0;
  float surfel_spacing = 0.f;
  uint32_t build_light_samples = 0;
};

std::string default_server() {
  const char* env = std::getenv("PBGI_SERVER");
  return env && *env ? env : "unix:./cache/pbgid.sock";
}

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// Progress lines on stderr: redrawn in place on a terminal, a line per
// quarter otherwise (so logs stay readable).
class Progress {
 public:
  explicit Progress(bool quiet) : quiet_(quiet), tty_(isatty(fileno(stderr)) != 0) {}

  void open(const std::string& stage, float fraction) {
    if (quiet_) return;
    if (tty_) {
      std::fprintf(stderr, "\ropen: %-24s %3.0f%% ", stage.c_str(), 100.f * fraction);
    } else if (stage != last_stage_) {
      std::fprintf(stderr, "open: %s\n", stage.c_str());
    }
    last_stage_ = stage;
    std::fflush(stderr);
  }
  void open_done() {
    if (!quiet_ && tty_ && !last_stage_.empty()) std::fputc('\n', stderr);
  }

  void tiles(uint32_t done, uint32_t total, double seconds) {
    if (quiet_) return;
    const double f = double(done) / total;
    const double eta = done > 0 ? seconds * (total - done) / done : 0;
    if (tty_) {
      constexpr int kWidth = 30;
      const int filled = int(f * kWidth + 0.5);
      std::fprintf(stderr, "\r[%s%s] %u/%u tiles  %.1fs  eta %.1fs ",
                   std::string(filled, '#').c_str(), std::string(kWidth - filled, ' ').c_str(),
                   done, total, seconds, eta);
      if (done == total) std::fputc('\n', stderr);
    } else if (int(f * 4) > quarter_ || done == total) {
      quarter_ = int(f * 4);
      std::fprintf(stderr, "render: %u/%u tiles, %.1fs, eta %.1fs\n", done, total, seconds, eta);
    }
    std::fflush(stderr);
  }

 private:
  bool quiet_, tty_;
  std::string last_stage_;
  int quarter_ = 0;
};

std::string pick_camera(const v1::SceneInfo& info, const std::string& requested) {
  if (!requested.empty()) return requested;
  if (info.cameras_size() == 1) return info.cameras(0);
  std::string known;
  for (const std::string& c : info.cameras()) known += (known.empty() ? "" : ", ") + c;
  throw InvalidArgument(fmt::format("scene '{}' has {} cameras: pass --camera ({})",
                                    info.scene_path(), info.cameras_size(),
                                    known.empty() ? "none" : known));
}

image::ExrImage to_exr(const client::Frame& frame, const RenderArgs& args,
                       const v1::SceneInfo& info, const std::string& camera) {
  image::ExrImage img(frame.width, frame.height);
  img.set_rgb("", frame.beauty);
  img.set_rgb("direct", frame.direct);
  img.set_rgb("indirect", frame.indirect);
  img.set_rgb("albedo", frame.albedo);
  img.set_layer("ao", image::y_channels(), frame.ao);
  img.attributes()["pbgi/scene"] = info.scene_path();
  img.attributes()["pbgi/scene_id"] = info.scene_id();
  img.attributes()["pbgi/camera"] = camera;
  img.attributes()["pbgi/server"] = args.server;
  return img;
}

int run_render(const RenderArgs& args) {
  const auto start = Clock::now();
  client::ClientOptions client_options;
  client_options.call_deadline =
      std::chrono::milliseconds(static_cast<int64_t>(args.tile_deadline * 1000));
  client::PbgiClient client(args.server, client_options);
  Progress progress(args.quiet);

  // 1. Open the scene (or join it if the daemon has it open already).
  v1::BuildOptions build;
  build.set_target_surfels(args.target_surfels);
  build.set_surfel_spacing(args.surfel_spacing);
  build.set_light_samples(args.build_light_samples);
  const v1::SceneInfo info = client.open_scene(
      client::scene_request_path(args.scene), build,
      [&](const std::string& stage, float fraction) { progress.open(stage, fraction); });
  progress.open_done();
  const double open_seconds = seconds_since(start);
  const std::string camera = pick_camera(info, args.camera);

  // 2. Render every tile.
  client::FrameRequest request;
  request.scene_id = info.scene_id();
  request.camera = camera;
  request.width = args.width;
  request.height = args.height;
  request.tile_size = args.tile;
  request.jobs = args.jobs;
  v1::GatherOptions& o = request.options;
  o.set_microbuffer_resolution(args.mb_res);
  o.set_max_solid_angle(args.max_solid_angle);
  o.set_ao_max_distance(args.ao_max_distance);
  o.set_light_samples(args.light_samples);
  o.set_pixel_samples(args.pixel_samples);
  if (args.method == "pbgi") o.set_method(v1::GatherOptions::PBGI);
  if (args.method == "fpbgi") o.set_method(v1::GatherOptions::FPBGI);
  o.set_clusters(args.clusters);
  o.set_epsilon(args.epsilon);
  o.set_hdr_refine(args.hdr_refine);
  const auto render_start = Clock::now();
  const client::Frame frame = client::render_frame(
      client, request,
      [&](uint32_t done, uint32_t total) { progress.tiles(done, total, seconds_since(render_start)); });
  const double render_seconds = seconds_since(render_start);

  // 3. Write the images.
  const image::ExrImage img = to_exr(frame, args, info, camera);
  image::ExrWriteOptions exr_options;
  exr_options.pixel_type = args.half ? image::ExrPixelType::Half : image::ExrPixelType::Float;
  image::write_exr(args.out, img, exr_options);
  std::string png_path;
  if (!args.no_png) {
    png_path = args.png.empty()
                   ? std::filesystem::path(args.out).replace_extension(".png").string()
                   : args.png;
    image::DisplayOptions display;
    display.exposure = args.exposure;
    image::write_png(png_path, img, "", display);
  }

  // 4. Report.
  std::printf("scene   %s (id %s, %llu triangles, %llu surfels%s)\n", info.scene_path().c_str(),
              info.scene_id().c_str(), static_cast<unsigned long long>(info.triangle_count()),
              static_cast<unsigned long long>(info.surfel_count()),
              info.reused_cache() ? ", cached tree" : "");
  std::printf("open    %.2f s\n", open_seconds);
  std::printf("render  %.2f s (%ux%u, %u tiles, %u in flight, %llu nodes visited)\n",
              render_seconds, frame.width, frame.height, frame.tiles, args.jobs,
              static_cast<unsigned long long>(frame.stats.nodes_visited()));
  std::printf("total   %.2f s\n", seconds_since(start));
  std::printf("wrote   %s\n", args.out.c_str());
  if (!png_path.empty()) std::printf("wrote   %s\n", png_path.c_str());
  return 0;
}

const CommandRegistrar kRegistrar{"render", [](CLI::App& app, int* exit_code) {
  auto args = std::make_shared<RenderArgs>();
  args->server = default_server();
  CLI::App* cmd = app.add_subcommand("render", "render a camera's image through a running pbgid");
  cmd->add_option("scene", args->scene, "USD scene (a local file or a path below the daemon's "
                                        "scene roots)")->required();
  cmd->add_option("--server", args->server, "pbgid address: unix:PATH or HOST:PORT "
                                            "($PBGI_SERVER)")->capture_default_str();
  cmd->add_option("--camera", args->camera, "camera prim path (default: the only camera)");
  cmd->add_option("--width", args->width, "image width")->capture_default_str();
  cmd->add_option("--height", args->height, "image height")->capture_default_str();
  cmd->add_option("--tile", args->tile, "tile size in pixels")->capture_default_str()
      ->check(CLI::Range(1u, 512u));
  cmd->add_option("--jobs", args->jobs, "tile requests in flight")->capture_default_str()
      ->check(CLI::Range(1u, 256u));
  cmd->add_option("--out", args->out, "multi-layer EXR output")->capture_default_str();
  cmd->add_option("--png", args->png, "PNG of the beauty (default: --out with .png)");
  cmd->add_flag("--no-png", args->no_png, "do not write the PNG");
  cmd->add_option("--exposure", args->exposure, "PNG exposure in stops");
  cmd->add_flag("--half", args->half, "store the EXR as half floats");
  cmd->add_flag("--quiet", args->quiet, "no progress on stderr");
  cmd->add_option("--tile-deadline", args->tile_deadline, "seconds allowed per tile request")
      ->capture_default_str();
  // Gather options; 0 = the daemon's default (shown in brackets).
  cmd->add_option("--mb-res", args->mb_res, "microbuffer resolution per cube face [8]");
  cmd->add_option("--max-solid-angle", args->max_solid_angle, "cut threshold, sr [0.03]");
  cmd->add_option("--ao-max-distance", args->ao_max_distance, "AO distance, 0 = unbounded");
  cmd->add_option("--light-samples", args->light_samples, "shadow rays per pixel and light [16]");
  cmd->add_option("--pixel-samples", args->pixel_samples, "camera rays per pixel [1]");
  cmd->add_option("--method", args->method, "gather: pbgi or fpbgi [pbgi]")
      ->check(CLI::IsMember({"pbgi", "fpbgi"}));
  cmd->add_option("--clusters", args->clusters, "FPBGI clusters per 1024 receivers [100]");
  cmd->add_option("--epsilon", args->epsilon, "FPBGI far/near split [0.01]");
  cmd->add_option("--hdr-refine", args->hdr_refine, "HDR-aware cut refinement, 0 = off");
  // Build options (they select which tree the daemon builds or reuses).
  cmd->add_option("--target-surfels", args->target_surfels, "surfels to sample [200000]");
  cmd->add_option("--surfel-spacing", args->surfel_spacing, "surfel spacing, world units");
  cmd->add_option("--build-light-samples", args->build_light_samples,
                  "shadow rays per surfel and light [16]");
  cmd->callback([args, exit_code] { *exit_code = run_render(*args); });
}};

}  // namespace
}  // namespace pbgi::cli
