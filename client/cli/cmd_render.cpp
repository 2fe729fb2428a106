// `pbgi render SCENE`: renders a camera's image through a running pbgid,
// tile by tile with several requests in flight, and writes the AOVs as a
// multi-layer EXR plus a display PNG of the beauty (through OCIO).
//
// Failed tiles are retried with back-off on UNAVAILABLE / RESOURCE_EXHAUSTED
// (the client library). Every finished tile is also appended to a sidecar
// file <out>.partial; `--resume` reads it back and renders only the tiles
// missing from it (after a crash, a daemon restart or Ctrl-C). The sidecar
// is removed once the images are written.
#include "client/cli/build_flags.h"
#include "client/cli/command.h"
#include "client/cli/connection_flags.h"
#include "client/cli/gather_flags.h"
#include "client/cli/open_progress.h"
#include "client/cli/output_paths.h"
#include "client/cli/scene_flags.h"
#include "client/cli/scene_warnings.h"
#include "client/image/exr_image.h"
#include "client/image/png_display.h"
#include "client/lib/frame_renderer.h"
#include "client/lib/pbgi_client.h"
#include "common/errors.h"

#include <fmt/format.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <unistd.h>

namespace pbgi::cli {
namespace {

using Clock = std::chrono::steady_clock;

struct RenderArgs {
  ConnectionArgs connection;
  bool resume = false;
  uint32_t max_new_tiles = 0;   // 0 = all
  int retries = 8;
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
  GatherArgs gather;
  BuildArgs build;
  SceneArgs composition;  // variants, time code
};

// Thrown from the tile callback to end a render early (--max-new-tiles).
struct StopRequested : std::exception {};

// The sidecar of finished tiles: a header naming the render, then one
// record per tile (rect + its AOVs as float32). A record cut short by a
// crash is ignored on resume.
class TileSidecar {
 public:
  static constexpr char kMagic[8] = {'P', 'B', 'G', 'I', 'R', 'S', 'M', '1'};

  // The identity a resumed render must match.
  static std::string header(const std::string& scene_id, const std::string& camera,
                            uint32_t width, uint32_t height, uint32_t tile,
                            const v1::GatherOptions& options) {
    return fmt::format("{}\n{}\n{}x{}/{}\n{}", scene_id, camera, width, height, tile,
                       options.SerializeAsString());
  }

  // Reads the tiles of a sidecar with this header; none if there is no
  // file. Throws InvalidArgument if it belongs to another render.
  static std::vector<client::TileImage> read(const std::string& path, const std::string& head) {
    std::vector<client::TileImage> tiles;
    std::ifstream in(path, std::ios::binary);
    if (!in) return tiles;
    char magic[8];
    uint32_t size = 0;
    if (!in.read(magic, 8) || std::memcmp(magic, kMagic, 8) != 0 ||
        !in.read(reinterpret_cast<char*>(&size), 4)) {
      throw InvalidArgument(fmt::format("'{}' is not a pbgi render sidecar", path));
    }
    std::string stored(size, '\0');
    in.read(stored.data(), size);
    if (stored != head) {
      throw InvalidArgument(fmt::format(
          "'{}' belongs to another render (scene, camera, size, tile size or options differ); "
          "delete it or render without --resume",
          path));
    }
    for (;;) {
      uint32_t rect[4];
      if (!in.read(reinterpret_cast<char*>(rect), sizeof rect)) break;
      client::TileImage t;
      t.tile.set_x0(rect[0]);
      t.tile.set_y0(rect[1]);
      t.tile.set_x1(rect[2]);
      t.tile.set_y1(rect[3]);
      if (rect[2] <= rect[0] || rect[3] <= rect[1]) break;
      const size_t pixels = size_t(t.width()) * t.height();
      bool complete = true;
      for (auto* aov : {&t.beauty, &t.direct, &t.indirect, &t.albedo, &t.ao}) {
        aov->resize(aov == &t.ao ? pixels : 3 * pixels);
        complete = complete && in.read(reinterpret_cast<char*>(aov->data()), aov->size() * 4);
      }
      if (!complete) break;
      tiles.push_back(std::move(t));
    }
    return tiles;
  }

  // Appends to `path` (starting it with the header if new or `fresh`).
  TileSidecar(const std::string& path, const std::string& head, bool fresh) : path_(path) {
    const bool exists = !fresh && std::filesystem::exists(path);
    out_.open(path, std::ios::binary | (exists ? std::ios::app : std::ios::trunc));
    if (!out_) throw IoError(fmt::format("cannot write render sidecar '{}'", path));
    if (!exists) {
      const uint32_t size = static_cast<uint32_t>(head.size());
      out_.write(kMagic, 8);
      out_.write(reinterpret_cast<const char*>(&size), 4);
      out_.write(head.data(), size);
      out_.flush();
    }
  }

  void append(const client::TileImage& t) {
    std::lock_guard lock(mutex_);
    const uint32_t rect[4] = {t.tile.x0(), t.tile.y0(), t.tile.x1(), t.tile.y1()};
    out_.write(reinterpret_cast<const char*>(rect), sizeof rect);
    for (const auto* aov : {&t.beauty, &t.direct, &t.indirect, &t.albedo, &t.ao}) {
      out_.write(reinterpret_cast<const char*>(aov->data()), aov->size() * 4);
    }
    out_.flush();  // a tile on disk is a tile a resume does not redo
  }

  void remove() {
    out_.close();
    std::error_code ec;
    std::filesystem::remove(path_, ec);
  }

 private:
  std::string path_;
  std::ofstream out_;
  std::mutex mutex_;
};

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// Tile progress on stderr: redrawn in place on a terminal, a line per
// quarter otherwise (so logs stay readable). The open's is open_progress.h.
class Progress {
 public:
  explicit Progress(bool quiet) : quiet_(quiet), tty_(isatty(fileno(stderr)) != 0) {}

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
  int quarter_ = 0;
};

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
  img.attributes()["pbgi/server"] = args.connection.server;
  return img;
}

// The PNG path of `args` ("" with --no-png).
std::string png_path_of(const RenderArgs& args) {
  if (args.no_png) return {};
  return args.png.empty() ? std::filesystem::path(args.out).replace_extension(".png").string() : args.png;
}

int run_render(const RenderArgs& args) {
  const auto start = Clock::now();
  // 0. Where the images go, before the scene is opened and rendered.
  check_output_file(args.out, "--out");
  const std::string png_path = png_path_of(args);
  if (!png_path.empty()) check_output_file(png_path, "--png");
  client::ClientOptions client_options = args.connection.client_options();
  client_options.call_deadline =
      std::chrono::milliseconds(static_cast<int64_t>(args.tile_deadline * 1000));
  client_options.max_attempts = std::max(1, args.retries + 1);
  client::PbgiClient client(args.connection.server, client_options);
  Progress progress(args.quiet);

  // 1. Open the scene (or join it if the daemon has it open already).
  const v1::OpenSceneRequest open_request =
      args.composition.request(client::scene_request_path(args.scene), args.build.to_proto(args.width, args.height));
  OpenProgressPrinter open_progress(stderr, isatty(fileno(stderr)) != 0, args.quiet);
  const v1::SceneInfo info = client.open_scene(open_request, std::ref(open_progress));
  open_progress.done();
  print_scene_warnings(info, stderr);
  const double open_seconds = seconds_since(start);
  const std::string camera = client::camera_for(info, args.camera);

  // 2. Render every tile.
  client::FrameRequest request;
  request.scene_id = info.scene_id();
  request.camera = camera;
  request.width = args.width;
  request.height = args.height;
  request.tile_size = args.tile;
  request.jobs = args.jobs;
  request.options = args.gather.to_proto();
  const v1::GatherOptions& o = request.options;

  // Finished tiles of an interrupted run of the same render, and the
  // sidecar this run records its tiles in.
  const std::string sidecar_path = args.out + ".partial";
  const std::string head = TileSidecar::header(info.scene_id(), camera, args.width, args.height,
                                               args.tile, o);
  if (args.resume) {
    request.done_tiles = TileSidecar::read(sidecar_path, head);
    if (!args.quiet) {
      std::fprintf(stderr, "resume: %zu tiles already done in %s\n", request.done_tiles.size(),
                   sidecar_path.c_str());
    }
  }
  const size_t resumed_tiles = request.done_tiles.size();
  TileSidecar sidecar(sidecar_path, head, /*fresh=*/!args.resume);
  uint32_t new_tiles = 0;
  request.on_tile = [&](const client::TileImage& tile) {
    sidecar.append(tile);
    // Calls are serialized: a plain counter will do.
    if (args.max_new_tiles > 0 && ++new_tiles >= args.max_new_tiles) throw StopRequested();
  };
  const auto render_start = Clock::now();
  client::Frame frame;
  try {
    frame = client::render_frame(client, request, [&](uint32_t done, uint32_t total) {
      progress.tiles(done, total, seconds_since(render_start));
    });
  } catch (const StopRequested&) {
    std::fprintf(stderr, "\nstopped after %u new tiles (--max-new-tiles); finished tiles are in "
                         "%s: rerun with --resume\n",
                 args.max_new_tiles, sidecar_path.c_str());
    return 3;
  }
  const double render_seconds = seconds_since(render_start);

  // 3. Write the images.
  const image::ExrImage img = to_exr(frame, args, info, camera);
  image::ExrWriteOptions exr_options;
  exr_options.pixel_type = args.half ? image::ExrPixelType::Half : image::ExrPixelType::Float;
  image::write_exr(args.out, img, exr_options);
  // The EXR holds every tile: the sidecar is done with, whatever the PNG does.
  sidecar.remove();
  if (!png_path.empty()) {
    image::DisplayOptions display;
    display.exposure = args.exposure;
    image::write_png(png_path, img, "", display);
  }

  // 4. Report.
  std::printf("scene   %s (id %s, %llu triangles, %llu surfels%s%s)\n", info.scene_path().c_str(),
              info.scene_id().c_str(), static_cast<unsigned long long>(info.triangle_count()),
              static_cast<unsigned long long>(info.surfel_count()),
              info.reused_ingest() ? ", stored ingest" : "", info.reused_cache() ? ", cached tree" : "");
  std::printf("open    %.2f s\n", open_seconds);
  std::printf("render  %.2f s (%ux%u, %u tiles, %zu resumed, %u in flight, %llu nodes visited)\n",
              render_seconds, frame.width, frame.height, frame.tiles, resumed_tiles, args.jobs,
              static_cast<unsigned long long>(frame.stats.nodes_visited()));
  if (frame.stats.pixels() > 0) {
    const double pixels = double(frame.stats.pixels());
    std::printf("gathers %.3f per pixel (%llu gathers, %.3g camera samples per pixel)\n",
                double(frame.stats.receivers()) / pixels, static_cast<unsigned long long>(frame.stats.receivers()),
                double(frame.stats.camera_samples()) / pixels);
  }
  std::printf("total   %.2f s\n", seconds_since(start));
  std::printf("wrote   %s\n", args.out.c_str());
  if (!png_path.empty()) std::printf("wrote   %s\n", png_path.c_str());
  return 0;
}

const CommandRegistrar kRegistrar{"render", [](CLI::App& app, int* exit_code) {
  auto args = std::make_shared<RenderArgs>();
  CLI::App* cmd = app.add_subcommand("render", "render a camera's image through a running pbgid");
  cmd->add_option("scene", args->scene, "USD scene (a local file or a path below the daemon's "
                                        "scene roots)")->required();
  args->connection.add_to(cmd);
  cmd->add_flag("--resume", args->resume,
                "skip the tiles an interrupted run of the same render finished (<out>.partial)");
  cmd->add_option("--max-new-tiles", args->max_new_tiles,
                  "stop (exit 3) after rendering this many tiles; continue with --resume");
  cmd->add_option("--retries", args->retries,
                  "retries per tile on UNAVAILABLE / RESOURCE_EXHAUSTED, with back-off")
      ->capture_default_str()->check(CLI::Range(0, 100));
  cmd->add_option("--camera,-c", args->camera, "camera prim path, or auto: the scene framed (default: the only camera; auto without any)");
  cmd->add_option("--width", args->width, "image width")->capture_default_str();
  cmd->add_option("--height", args->height, "image height")->capture_default_str();
  cmd->add_option("--tile", args->tile, "tile size in pixels")->capture_default_str()
      ->check(CLI::Range(1u, 512u));
  cmd->add_option("--jobs,-j", args->jobs, "tile requests in flight")->capture_default_str()
      ->check(CLI::Range(1u, 256u));
  cmd->add_option("--out,-o", args->out, "multi-layer EXR output")->capture_default_str();
  cmd->add_option("--png", args->png, "PNG of the beauty (default: --out with .png)");
  cmd->add_flag("--no-png", args->no_png, "do not write the PNG");
  cmd->add_option("--exposure", args->exposure, "PNG exposure in stops");
  cmd->add_flag("--half", args->half, "store the EXR as half floats");
  cmd->add_flag("--quiet,-q", args->quiet, "no progress on stderr");
  cmd->add_option("--tile-deadline", args->tile_deadline, "seconds allowed per tile request")
      ->capture_default_str();
  // Which composition of the stage: variant selections, time code.
  args->composition.add_to(cmd);
  // Gather options; 0 = the daemon's default (shown in brackets).
  args->gather.add_to(cmd);
  // Build options (they select which tree the daemon builds or reuses).
  args->build.add_to(cmd);
  cmd->callback([args, exit_code] { *exit_code = run_render(*args); });
}};

}  // namespace
}  // namespace pbgi::cli
