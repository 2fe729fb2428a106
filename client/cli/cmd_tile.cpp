// `pbgi tile SCENE --tile-rect x0,y0,x1,y1`: renders one tile through a
// running pbgid, writes its AOVs as a tile-sized multi-layer EXR and prints
// the gather statistics of that tile (text, or JSON with --json).
#include "client/cli/build_flags.h"
#include "client/cli/command.h"
#include "client/cli/connection_flags.h"
#include "client/cli/gather_flags.h"
#include "client/cli/scene_flags.h"
#include "client/cli/scene_warnings.h"
#include "client/image/exr_image.h"
#include "client/lib/pbgi_client.h"
#include "common/errors.h"

#include <fmt/format.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>

namespace pbgi::cli {
namespace {

struct TileArgs {
  ConnectionArgs connection;
  std::string scene;
  std::string camera;
  uint32_t width = 512, height = 512;
  std::string rect = "0,0,32,32";
  std::string out = "tile.exr";
  bool json = false;
  GatherArgs gather;
  BuildArgs build;
  SceneArgs composition;  // variants, time code
};

// "x0,y0,x1,y1" -> Tile; throws InvalidArgument naming the flag.
v1::Tile parse_rect(const std::string& text) {
  unsigned v[4];
  char tail = 0;
  if (std::sscanf(text.c_str(), "%u,%u,%u,%u%c", &v[0], &v[1], &v[2], &v[3], &tail) != 4) {
    throw InvalidArgument(fmt::format("--tile-rect '{}' is not x0,y0,x1,y1", text));
  }
  v1::Tile tile;
  tile.set_x0(v[0]);
  tile.set_y0(v[1]);
  tile.set_x1(v[2]);
  tile.set_y1(v[3]);
  return tile;
}

int run_tile(const TileArgs& args) {
  client::PbgiClient client(args.connection.server, args.connection.client_options());

  // 1. Open (quietly: the statistics are this command's output).
  const v1::OpenSceneRequest open_request =
      args.composition.request(client::scene_request_path(args.scene), args.build.to_proto(args.width, args.height));
  const v1::SceneInfo info = client.open_scene(open_request, {});
  print_scene_warnings(info, stderr);  // stdout holds the statistics
  const std::string camera = client::camera_for(info, args.camera);

  // 2. One tile.
  v1::RenderTileRequest request;
  request.set_scene_id(info.scene_id());
  request.set_camera(camera);
  request.set_image_width(args.width);
  request.set_image_height(args.height);
  *request.mutable_tile() = parse_rect(args.rect);
  *request.mutable_options() = args.gather.to_proto();
  const auto start = std::chrono::steady_clock::now();
  const client::TileImage tile = client.render_tile(request);
  const double round_trip =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  // 3. The tile as its own small image.
  image::ExrImage img(tile.width(), tile.height());
  img.set_rgb("", tile.beauty);
  img.set_rgb("direct", tile.direct);
  img.set_rgb("indirect", tile.indirect);
  img.set_rgb("albedo", tile.albedo);
  img.set_layer("ao", image::y_channels(), tile.ao);
  img.attributes()["pbgi/scene"] = info.scene_path();
  img.attributes()["pbgi/camera"] = camera;
  img.attributes()["pbgi/tile"] = fmt::format("{},{},{},{} of {}x{}", tile.tile.x0(),
                                              tile.tile.y0(), tile.tile.x1(), tile.tile.y1(),
                                              args.width, args.height);
  image::write_exr(args.out, img);

  // 4. Statistics.
  const v1::GatherStats& s = tile.stats;
  if (args.json) {
    std::printf(
        "{\"scene_id\": \"%s\", \"tile\": [%u, %u, %u, %u], \"receivers\": %llu, "
        "\"nodes_visited\": %llu, \"nodes_rasterized\": %llu, \"surfels_raycast\": %llu, "
        "\"camera_samples\": %llu, \"pixels\": %llu, "
        "\"seconds\": %.6f, \"round_trip_seconds\": %.6f, \"out\": \"%s\"}\n",
        info.scene_id().c_str(), tile.tile.x0(), tile.tile.y0(), tile.tile.x1(), tile.tile.y1(),
        static_cast<unsigned long long>(s.receivers()),
        static_cast<unsigned long long>(s.nodes_visited()),
        static_cast<unsigned long long>(s.nodes_rasterized()),
        static_cast<unsigned long long>(s.surfels_raycast()),
        static_cast<unsigned long long>(s.camera_samples()), static_cast<unsigned long long>(s.pixels()),
        s.seconds(), round_trip,
        args.out.c_str());
  } else {
    std::printf("tile               %u,%u,%u,%u of %ux%u\n", tile.tile.x0(), tile.tile.y0(),
                tile.tile.x1(), tile.tile.y1(), args.width, args.height);
    std::printf("receivers          %llu (gathers; %.3f per pixel)\n", static_cast<unsigned long long>(s.receivers()),
                s.pixels() ? double(s.receivers()) / double(s.pixels()) : 0.0);
    std::printf("camera samples     %llu\n", static_cast<unsigned long long>(s.camera_samples()));
    std::printf("nodes visited      %llu\n", static_cast<unsigned long long>(s.nodes_visited()));
    std::printf("nodes rasterized   %llu\n", static_cast<unsigned long long>(s.nodes_rasterized()));
    std::printf("surfels ray-cast   %llu\n", static_cast<unsigned long long>(s.surfels_raycast()));
    std::printf("seconds            %.4f (server), %.4f (round trip)\n", s.seconds(), round_trip);
    std::printf("wrote              %s\n", args.out.c_str());
  }
  return 0;
}

const CommandRegistrar kRegistrar{"tile", [](CLI::App& app, int* exit_code) {
  auto args = std::make_shared<TileArgs>();
  CLI::App* cmd = app.add_subcommand("tile", "render one tile through a running pbgid and "
                                             "print its gather statistics");
  cmd->add_option("scene", args->scene, "USD scene")->required();
  args->connection.add_to(cmd);
  cmd->add_option("--camera,-c", args->camera, "camera prim path, or auto: the scene framed (default: the only camera; auto without any)");
  cmd->add_option("--width", args->width, "image width")->capture_default_str();
  cmd->add_option("--height", args->height, "image height")->capture_default_str();
  cmd->add_option("--tile-rect", args->rect, "x0,y0,x1,y1 (x1, y1 exclusive)")
      ->capture_default_str();
  cmd->add_option("--out,-o", args->out, "EXR of the tile")->capture_default_str();
  cmd->add_flag("--json", args->json, "statistics as one JSON object");
  args->composition.add_to(cmd);
  args->gather.add_to(cmd);
  args->build.add_to(cmd);
  cmd->callback([args, exit_code] { *exit_code = run_tile(*args); });
}};

}  // namespace
}  // namespace pbgi::cli
