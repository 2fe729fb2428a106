// End to end: pbgid as a child process on a temporary unix socket, driven
// through the client library and the pbgi CLI on scenes/cornell.usda.
//   - a 64x64 render tile by tile: finite AOVs, colour bleeding from the
//     red and green walls onto the floor, a ceiling lit only indirectly;
//   - the same physics through explicit Gather receivers;
//   - bad requests get NOT_FOUND / PERMISSION_DENIED / INVALID_ARGUMENT /
//     OUT_OF_RANGE and the daemon keeps serving;
//   - `pbgi render` writes a readable EXR and PNG;
//   - a 1 ms deadline is honoured, cancelled work stops promptly, overload
//     is refused with a retry hint, RenderTiles streams tiles, status and
//     unload work, malformed / oversized / NaN / empty requests get their
//     codes, and after all of it the daemon answers health and renders;
//   - SIGTERM stops the daemon cleanly and removes its socket.
// The daemon runs with a small admission limit (2 in flight, 2 queued) and
// a config file ([limits]) so that these paths are exercised.
#include "client/image/exr_image.h"
#include "client/lib/frame_renderer.h"
#include "client/lib/pbgi_client.h"
#include "tests/support/daemon_process.h"

#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <future>
#include <limits>
#include <cstdio>
#include <fstream>
#include <thread>

namespace fs = std::filesystem;

namespace pbgi {
namespace {

using client::PbgiClient;
using client::RpcError;

const fs::path kSourceDir = PBGI_TEST_SOURCE_DIR;
const fs::path kBinaryDir = PBGI_TEST_BINARY_DIR;
const fs::path kCornell = kSourceDir / "scenes" / "cornell.usda";
constexpr uint32_t kSize = 64;

// Small enough to keep the whole suite well under a minute on two cores.
v1::BuildOptions small_build() {
  v1::BuildOptions b;
  b.set_target_surfels(20000);
  b.set_light_samples(4);
  return b;
}
v1::GatherOptions fast_gather() {
  v1::GatherOptions o;
  o.set_light_samples(4);
  return o;
}

// One daemon and one open scene per test process (ctest runs each test in
// its own process; a plain run of the binary shares them).
class Integration : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    const fs::path config = kBinaryDir / "tests" / "integration_pbgid.toml";
    fs::create_directories(config.parent_path());
    std::ofstream(config) << "[limits]\nmax_receivers = 200000\nmax_message_size = \"8MiB\"\n"
                             "max_in_flight = 2\nmax_queued = 2\n";
    daemon = new testing::DaemonProcess(
        kBinaryDir / "bin" / "pbgid",
        {"--config", config.string(), "--scene-root", (kSourceDir / "scenes").string(),
         "--log-level", "info"});
    client = new PbgiClient(daemon->address());
    info = new v1::SceneInfo(client->open_scene(kCornell.string(), small_build()));
  }
  static void TearDownTestSuite() {
    delete info;
    delete client;
    const fs::path socket = daemon->socket_path();
    const int status = daemon->terminate();
    EXPECT_EQ(status, 0) << "pbgid exits cleanly on SIGTERM\n" << daemon->log();
    EXPECT_FALSE(fs::exists(socket)) << "pbgid removes its socket";
    delete daemon;
  }

  // The daemon still answers a valid request.
  static void expect_serving() {
    const auto out = client->gather(info->scene_id(), {{0, 1, 0}}, {{0, 1, 0}}, fast_gather());
    ASSERT_EQ(out.irradiance.size(), 1u);
    EXPECT_TRUE(std::isfinite(out.irradiance[0].x));
  }

  // grpc.health.v1.Health/Check for the whole server: SERVING is the
  // message {status: 1}, bytes 08 01.
  static bool healthy() {
    grpc::GenericStub stub(grpc::CreateChannel(daemon->address(), grpc::InsecureChannelCredentials()));
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
    grpc::Slice empty_message("", 0);
    grpc::ByteBuffer request(&empty_message, 1), response;
    std::promise<grpc::Status> done;
    stub.UnaryCall(&context, "/grpc.health.v1.Health/Check", grpc::StubOptions(), &request,
                   &response, [&](grpc::Status s) { done.set_value(s); });
    if (!done.get_future().get().ok()) return false;
    std::vector<grpc::Slice> slices;
    response.Dump(&slices);
    std::string bytes;
    for (const auto& sl : slices) bytes.append(reinterpret_cast<const char*>(sl.begin()), sl.size());
    return bytes == std::string("\x08\x01", 2);
  }

  // Polls GetStatus until no gather or tile runs (in 3 polls in a row: a
  // stream holds no slot between its tiles); the time it took.
  static std::chrono::milliseconds wait_until_idle(std::chrono::milliseconds limit) {
    const auto start = std::chrono::steady_clock::now();
    int idle_polls = 0;
    for (;;) {
      const v1::GetStatusResponse status = client->status();
      const bool idle = status.requests().in_flight() == 0 && status.requests().queued() == 0;
      idle_polls = idle ? idle_polls + 1 : 0;
      const auto waited = std::chrono::duration_cast<std::chrono::milliseconds>(
          std::chrono::steady_clock::now() - start);
      if (idle_polls == 3 || waited > limit) return waited;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
  }

  // n receivers on the floor, facing up.
  static void floor_receivers(size_t n, std::vector<Imath::V3f>* p, std::vector<Imath::V3f>* nrm) {
    p->resize(n);
    nrm->assign(n, Imath::V3f(0, 1, 0));
    for (size_t i = 0; i < n; ++i) {
      (*p)[i] = Imath::V3f(-0.9f + 1.8f * float(i % 97) / 96.f, 0.001f,
                           -0.9f + 1.8f * float(i / 97 % 97) / 96.f);
    }
  }

  static grpc::StatusCode code_of(const std::function<void()>& call, std::string* message) {
    try {
      call();
    } catch (const RpcError& e) {
      *message = e.what();
      return e.code();
    }
    return grpc::StatusCode::OK;
  }

  static testing::DaemonProcess* daemon;
  static PbgiClient* client;
  static v1::SceneInfo* info;
};
testing::DaemonProcess* Integration::daemon = nullptr;
PbgiClient* Integration::client = nullptr;
v1::SceneInfo* Integration::info = nullptr;

// Where the camera ray of a pixel meets the plane y = plane_y (the scene's
// camera: at (0, 1, 3.4) looking down -Z, square apertures of 25.477917 mm
// and a 35 mm focal length). False if it does not meet it going forward.
bool pixel_hits_plane(uint32_t px, uint32_t py, float plane_y, float* x, float* z) {
  const float half = 0.5f * 25.477917f / 35.f;
  const float dx = (2.f * (px + 0.5f) / kSize - 1.f) * half;
  const float dy = (1.f - 2.f * (py + 0.5f) / kSize) * half;
  const float t = (plane_y - 1.f) / dy;   // along (dx, dy, -1) from y = 1
  if (!(t > 0)) return false;
  *x = t * dx;
  *z = 3.4f - t;
  return true;
}

struct Rgb {
  double r = 0, g = 0, b = 0;
  int n = 0;
  void add(const float* p) { r += p[0]; g += p[1]; b += p[2]; ++n; }
};

// Runs the pbgi CLI in `dir`; returns its exit status, stdout + stderr in `text`.
int run_cli(const std::vector<std::string>& args, const fs::path& dir, std::string* text) {
  std::vector<std::string> argv = {(kBinaryDir / "bin" / "pbgi").string()};
  argv.insert(argv.end(), args.begin(), args.end());
  const pid_t pid = testing::spawn(argv, dir / "cli.out", dir / "cli.err");
  const int status = testing::wait_for_exit(pid, std::chrono::seconds(60));
  std::ifstream out(dir / "cli.out"), err(dir / "cli.err");
  // (Inserting an empty streambuf sets failbit and drops what follows:
  // read the two files separately.)
  std::stringstream o, e;
  o << out.rdbuf();
  e << err.rdbuf();
  *text = o.str() + e.str();
  return status;
}

TEST_F(Integration, SceneInfo) {
  EXPECT_EQ(info->scene_path(), fs::canonical(kCornell).string());
  EXPECT_GT(info->triangle_count(), 0u);
  EXPECT_GT(info->surfel_count(), 10000u);
  EXPECT_GT(info->page_count(), 0u);
  ASSERT_EQ(info->cameras_size(), 1);
  EXPECT_EQ(info->cameras(0), "/Camera");
  // The same scene and options again: the same session, at once.
  const v1::SceneInfo again = client->open_scene(kCornell.string(), small_build());
  EXPECT_EQ(again.scene_id(), info->scene_id());
  EXPECT_EQ(client->list_scenes().size(), 1u);

  // Two clients asking at once for a scene not open yet share one open.
  v1::BuildOptions other = small_build();
  other.set_target_surfels(5000);
  v1::SceneInfo first, second;
  std::thread a([&] { first = PbgiClient(daemon->address()).open_scene(kCornell.string(), other); });
  std::thread b([&] { second = PbgiClient(daemon->address()).open_scene(kCornell.string(), other); });
  a.join();
  b.join();
  EXPECT_EQ(first.scene_id(), second.scene_id());
  EXPECT_NE(first.scene_id(), info->scene_id()) << "other build options, other tree";
  EXPECT_EQ(client->list_scenes().size(), 2u);
}

TEST_F(Integration, RenderShowsColourBleedingAndIndirectOnlyCeiling) {
  client::FrameRequest request;
  request.scene_id = info->scene_id();
  request.camera = "/Camera";
  request.width = kSize;
  request.height = kSize;
  request.tile_size = 16;
  request.jobs = 4;
  request.options = fast_gather();
  const client::Frame frame = client::render_frame(*client, request);

  // 1. Every AOV finite.
  for (const auto* aov : {&frame.beauty, &frame.direct, &frame.indirect, &frame.albedo, &frame.ao}) {
    for (size_t i = 0; i < aov->size(); ++i) ASSERT_TRUE(std::isfinite((*aov)[i])) << "at " << i;
  }

  // 2. Floor pixels in front of the boxes, next to each wall; ceiling
  //    pixels away from the light (which spans |x| < 0.25, |z| < 0.2).
  Rgb floor_red, floor_green, ceiling_direct, ceiling_indirect;
  for (uint32_t py = 0; py < kSize; ++py) {
    for (uint32_t px = 0; px < kSize; ++px) {
      const size_t i = 3 * (size_t(py) * kSize + px);
      float x, z;
      if (pixel_hits_plane(px, py, 0.f, &x, &z) && z > 0.15f && z < 0.9f) {
        if (x > -0.95f && x < -0.75f) floor_red.add(&frame.indirect[i]);
        if (x > 0.75f && x < 0.95f) floor_green.add(&frame.indirect[i]);
      }
      if (pixel_hits_plane(px, py, 2.f, &x, &z) && std::abs(x) > 0.45f && std::abs(x) < 0.95f &&
          z > -0.9f && z < 0.9f) {
        ceiling_direct.add(&frame.direct[i]);
        ceiling_indirect.add(&frame.indirect[i]);
      }
    }
  }
  ASSERT_GE(floor_red.n, 5);
  ASSERT_GE(floor_green.n, 5);
  ASSERT_GE(ceiling_direct.n, 5);
  const double red_ratio = floor_red.r / floor_red.g;
  const double green_ratio = floor_green.r / floor_green.g;
  EXPECT_GT(red_ratio, 1.5) << "floor by the red wall: indirect R/G";
  EXPECT_GT(red_ratio, green_ratio) << "redder by the red wall than by the green one";
  EXPECT_LT(green_ratio, 1.0) << "greener by the green wall";

  const double direct = (ceiling_direct.r + ceiling_direct.g + ceiling_direct.b) / ceiling_direct.n;
  const double indirect =
      (ceiling_indirect.r + ceiling_indirect.g + ceiling_indirect.b) / ceiling_indirect.n;
  std::printf("render: floor indirect R/G %.2f by the red wall (%d px), %.2f by the green wall "
              "(%d px); ceiling direct %.2g, indirect %.3g (%d px)\n",
              red_ratio, floor_red.n, green_ratio, floor_green.n, direct, indirect,
              ceiling_direct.n);
  EXPECT_GT(indirect, 1e-3) << "the ceiling is lit by the room";
  EXPECT_LT(direct, 1e-3) << "but not by the downward-facing light";
  EXPECT_GT(frame.stats.nodes_visited(), 0u);
}

TEST_F(Integration, GatherShowsColourBleedingAndIndirectOnlyCeiling) {
  // Receivers on the floor next to each wall, in front of the boxes, and
  // on the ceiling's corners, facing into the room.
  std::vector<Imath::V3f> positions, normals;
  for (float z : {0.2f, 0.4f, 0.6f}) {
    positions.push_back({-0.9f, 0.001f, z});
    normals.push_back({0, 1, 0});
  }
  for (float z : {0.2f, 0.4f, 0.6f}) {
    positions.push_back({0.9f, 0.001f, z});
    normals.push_back({0, 1, 0});
  }
  for (float x : {-0.7f, 0.7f}) {
    for (float z : {-0.6f, 0.6f}) {
      positions.push_back({x, 1.999f, z});
      normals.push_back({0, -1, 0});
    }
  }
  const client::GatherOutput out =
      client->gather(info->scene_id(), positions, normals, fast_gather());
  ASSERT_EQ(out.irradiance.size(), positions.size());
  // Gathered (receivers) and sent: interpolation may gather fewer.
  EXPECT_EQ(out.stats.requested_receivers(), positions.size());
  EXPECT_GT(out.stats.receivers(), 0u);
  EXPECT_LE(out.stats.receivers(), positions.size());
  Imath::C3f red(0, 0, 0), green(0, 0, 0);
  for (int i = 0; i < 3; ++i) red += out.irradiance[i];
  for (int i = 3; i < 6; ++i) green += out.irradiance[i];
  std::printf("gather: floor R/G %.2f by the red wall, %.2f by the green wall; ceiling "
              "irradiance %.3g %.3g %.3g %.3g\n",
              red.x / red.y, green.x / green.y, out.irradiance[6].y, out.irradiance[7].y,
              out.irradiance[8].y, out.irradiance[9].y);
  EXPECT_GT(red.x / red.y, 1.5f) << "by the red wall: R/G of the irradiance";
  EXPECT_GT(red.x / red.y, green.x / green.y);
  EXPECT_GT(green.y, green.x) << "by the green wall: greener";
  for (size_t i = 6; i < positions.size(); ++i) {
    const Imath::C3f e = out.irradiance[i];
    EXPECT_GT(e.x + e.y + e.z, 1e-3f) << "ceiling receiver " << i << " gets indirect light";
    EXPECT_TRUE(out.ao[i] >= 0.f && out.ao[i] <= 1.f);
  }
}

TEST_F(Integration, BadRequestsGetTheRightStatusAndTheDaemonKeepsServing) {
  std::string message;

  // Missing scene inside the root.
  EXPECT_EQ(code_of([&] { client->open_scene((kSourceDir / "scenes" / "nope.usda").string()); },
                    &message),
            grpc::StatusCode::NOT_FOUND);
  EXPECT_NE(message.find("nope.usda"), std::string::npos) << message;
  expect_serving();

  // Outside every scene root, directly or through "..".
  EXPECT_EQ(code_of([&] { client->open_scene("/etc/passwd"); }, &message),
            grpc::StatusCode::PERMISSION_DENIED);
  EXPECT_NE(message.find("/etc/passwd"), std::string::npos) << message;
  expect_serving();
  EXPECT_EQ(code_of([&] { client->open_scene("../CMakeLists.txt"); }, &message),
            grpc::StatusCode::PERMISSION_DENIED);
  EXPECT_EQ(code_of([&] { client->open_scene((kSourceDir / "scenes" / ".." / "CMakeLists.txt").string()); },
                    &message),
            grpc::StatusCode::PERMISSION_DENIED);
  expect_serving();

  // Malformed Gather: positions not a multiple of 12 bytes.
  v1::GatherRequest gather;
  gather.set_scene_id(info->scene_id());
  gather.set_positions(std::string(13, '\0'));
  gather.set_normals(std::string(13, '\0'));
  EXPECT_EQ(code_of([&] { client->gather_raw(gather); }, &message),
            grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(message.find("positions"), std::string::npos) << message;
  expect_serving();

  // Unknown scene id.
  EXPECT_EQ(code_of([&] { client->gather("not-a-scene", {{0, 1, 0}}, {{0, 1, 0}}); }, &message),
            grpc::StatusCode::NOT_FOUND);
  EXPECT_NE(message.find("not-a-scene"), std::string::npos) << message;

  // Tile outside the image; unknown camera.
  v1::RenderTileRequest tile;
  tile.set_scene_id(info->scene_id());
  tile.set_camera("/Camera");
  tile.set_image_width(kSize);
  tile.set_image_height(kSize);
  tile.mutable_tile()->set_x0(48);
  tile.mutable_tile()->set_y0(48);
  tile.mutable_tile()->set_x1(80);
  tile.mutable_tile()->set_y1(64);
  EXPECT_EQ(code_of([&] { client->render_tile(tile); }, &message), grpc::StatusCode::OUT_OF_RANGE);
  EXPECT_NE(message.find("[48,80)"), std::string::npos) << message;
  EXPECT_NE(message.find("64x64"), std::string::npos) << message;
  expect_serving();
  tile.mutable_tile()->set_x1(64);
  tile.set_camera("/NoSuchCamera");
  EXPECT_EQ(code_of([&] { client->render_tile(tile); }, &message), grpc::StatusCode::NOT_FOUND);
  EXPECT_NE(message.find("/NoSuchCamera"), std::string::npos) << message;

  // A deadline too short for the tile: the render is cancelled.
  client::ClientOptions hurried;
  hurried.call_deadline = std::chrono::milliseconds(20);
  v1::RenderTileRequest big = tile;
  big.set_camera("/Camera");
  big.mutable_tile()->set_x0(0);
  big.mutable_tile()->set_y0(0);
  EXPECT_EQ(code_of([&] { PbgiClient(daemon->address(), hurried).render_tile(big); }, &message),
            grpc::StatusCode::DEADLINE_EXCEEDED);
  expect_serving();

  // And a valid tile still renders.
  tile.set_camera("/Camera");
  *tile.mutable_options() = fast_gather();
  const client::TileImage image = client->render_tile(tile);
  EXPECT_EQ(image.beauty.size(), 3u * 16 * 16);
}

TEST_F(Integration, CliRenderWritesExrAndPng) {
  const fs::path out = daemon->dir() / "cli" / "cornell.exr";
  fs::create_directories(out.parent_path());
  std::string text;
  const int status = run_cli(
      {"render", kCornell.string(), "--server", daemon->address(), "--camera", "/Camera",
       "--width", "32", "--height", "24", "--tile", "16", "--jobs", "2", "--out", out.string(),
       "--light-samples", "4", "--target-surfels", "20000", "--build-light-samples", "4"},
      daemon->dir(), &text);
  ASSERT_EQ(status, 0) << text;
  EXPECT_NE(text.find(out.string()), std::string::npos) << "prints the paths\n" << text;
  EXPECT_NE(text.find("total"), std::string::npos) << "prints timings\n" << text;

  const image::ExrImage exr = image::read_exr(out.string());
  EXPECT_EQ(exr.width(), 32u);
  EXPECT_EQ(exr.height(), 24u);
  for (const char* channel : {"R", "G", "B", "direct.R", "indirect.G", "albedo.B", "ao.Y"}) {
    EXPECT_TRUE(exr.has_channel(channel)) << channel;
  }
  float sum = 0;
  for (float v : exr.channel("G")) sum += v;
  EXPECT_GT(sum, 0.f) << "the beauty is not black";

  const fs::path png = fs::path(out).replace_extension(".png");
  std::ifstream png_file(png, std::ios::binary);
  char signature[8] = {};
  png_file.read(signature, 8);
  EXPECT_EQ(std::string(signature, 8), std::string("\x89PNG\r\n\x1a\n", 8)) << png;
}

// An asset as DCCs export it (no camera, no light, a variant set) renders
// with no flag but the scene: framed by the auto camera, with a warning
// that nothing lights it; --default-light lights it; variant selections
// that select nothing are refused, naming what the stage has.
TEST_F(Integration, BareAssetRendersWithAutoCameraAndWarnings) {
  const fs::path asset = kSourceDir / "scenes" / "bare_asset.usda";
  const fs::path dir = daemon->dir() / "bare";
  fs::create_directories(dir);
  const std::vector<std::string> common = {"--server", daemon->address(), "--width", "32", "--height", "24",
                                           "--light-samples", "4", "--target-surfels", "20000",
                                           "--build-light-samples", "4", "-q"};
  auto render = [&](std::vector<std::string> extra, const std::string& name, std::string* text) {
    std::vector<std::string> args = {"render", asset.string(), "-o", (dir / name).string()};
    args.insert(args.end(), common.begin(), common.end());
    args.insert(args.end(), extra.begin(), extra.end());
    return run_cli(args, dir, text);
  };
  auto sum = [](const image::ExrImage& img, const char* channel) {
    double total = 0;
    for (float v : img.channel(channel)) total += v;
    return total;
  };

  std::string text;
  ASSERT_EQ(render({}, "dark.exr", &text), 0) << text;
  EXPECT_NE(text.find("warning: the scene has no light"), std::string::npos) << text;
  const image::ExrImage dark = image::read_exr((dir / "dark.exr").string());
  EXPECT_GT(sum(dark, "albedo.R"), 0.0) << "the auto camera sees the asset";
  EXPECT_EQ(sum(dark, "G"), 0.0) << "nothing lights it";
  const std::string auto_camera = dark.attributes().at("pbgi/camera");
  EXPECT_EQ(auto_camera, "auto");

  ASSERT_EQ(render({"--default-light", "--variant", "/Asset:color=blue"}, "lit.exr", &text), 0) << text;
  EXPECT_EQ(text.find("no light"), std::string::npos) << text;
  const image::ExrImage lit = image::read_exr((dir / "lit.exr").string());
  EXPECT_GT(sum(lit, "G"), 0.0) << "the default lights light it";
  EXPECT_GT(sum(lit, "albedo.B"), sum(dark, "albedo.B")) << "the blue variant was selected";

  ASSERT_NE(render({"--variant", "/Asset:color=green", "--variant", "/Nope:color=red"}, "bad.exr", &text), 0);
  EXPECT_NE(text.find("/Asset: variant selection color=green: not one of blue, red"), std::string::npos) << text;
  EXPECT_NE(text.find("/Nope: variant selection color=red: no such prim"), std::string::npos) << text;
  v1::OpenSceneRequest request;
  request.set_scene_path(asset.string());
  *request.mutable_build() = small_build();
  (*request.mutable_variant_selections())["/Asset:look"] = "red";
  std::string message;
  EXPECT_EQ(code_of([&] { client->open_scene(request, {}); }, &message), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(message.find("the prim has no variant set 'look' (it has: color)"), std::string::npos) << message;
}

// The USD Working Group's Teapot and Vehicles (../shared/scenes, when the
// checkout has it beside it) render with no flag but the scene: they have
// no camera and no light, and Vehicles a variant set -- the auto camera
// frames them, the CLI says that nothing lights them, and the render is
// not refused. (A small image and surfel budget keep the test short; no
// flag names a camera, a light or a variant.)
TEST(UsdWgAssets, TeapotAndVehiclesRenderWithNoFlagButTheScene) {
  const fs::path shared = (kSourceDir / ".." / "shared" / "scenes").lexically_normal();
  const fs::path assets = shared / "usd-wg" / "full_assets";
  if (!fs::is_directory(assets)) GTEST_SKIP() << assets << " is not present";
  testing::DaemonProcess daemon(kBinaryDir / "bin" / "pbgid", {"--scene-root", shared.string()});
  for (const fs::path& scene : {assets / "Teapot" / "Teapot.usd", assets / "Vehicles" / "USD_Mini_Car_Kit" / "assets" /
                                                                      "vehicles" / "vehicleVariants.usda"}) {
    SCOPED_TRACE(scene.string());
    const fs::path out = daemon.dir() / (scene.stem().string() + ".exr");
    std::string text;
    ASSERT_EQ(run_cli({"render", scene.string(), "--server", daemon.address(), "-o", out.string(), "--width", "32",
                       "--height", "24", "--target-surfels", "20000", "--light-samples", "4", "--build-light-samples",
                       "4", "-q"},
                      daemon.dir(), &text),
              0)
        << text;
    EXPECT_NE(text.find("warning: the scene has no light"), std::string::npos) << text;
    const image::ExrImage img = image::read_exr(out.string());
    EXPECT_EQ(img.attributes().at("pbgi/camera"), "auto");
    double albedo = 0;
    size_t covered = 0;
    for (const float v : img.channel("albedo.G")) {
      albedo += v;
      covered += v > 0.f;
    }
    EXPECT_GT(albedo, 0.0) << "the auto camera sees the asset";
    EXPECT_GT(covered, 32u * 24u / 20u) << "the asset fills a part of the frame";
  }
}

TEST_F(Integration, OneMillisecondDeadlineIsHonoured) {
  client::ClientOptions hurried;
  hurried.call_deadline = std::chrono::milliseconds(1);
  PbgiClient impatient(daemon->address(), hurried);
  std::vector<Imath::V3f> p, n;
  floor_receivers(2000, &p, &n);
  std::string message;
  EXPECT_EQ(code_of([&] { impatient.gather(info->scene_id(), p, n, fast_gather()); }, &message),
            grpc::StatusCode::DEADLINE_EXCEEDED)
      << message;
  v1::RenderTileRequest tile;
  tile.set_scene_id(info->scene_id());
  tile.set_camera("/Camera");
  tile.set_image_width(kSize);
  tile.set_image_height(kSize);
  tile.mutable_tile()->set_x1(kSize);
  tile.mutable_tile()->set_y1(kSize);
  EXPECT_EQ(code_of([&] { impatient.render_tile(tile); }, &message),
            grpc::StatusCode::DEADLINE_EXCEEDED)
      << message;
  EXPECT_LT(wait_until_idle(std::chrono::seconds(5)), std::chrono::seconds(2));
  expect_serving();
}

TEST_F(Integration, CancelledWorkStopsPromptly) {
  // What one receiver costs here, to know how long the big gather would run
  // (every receiver gathered: interpolation would make the cost depend on
  // the receivers' density).
  v1::GatherOptions every = fast_gather();
  every.set_interpolation(v1::GatherOptions::INTERPOLATION_OFF);
  std::vector<Imath::V3f> p, n;
  floor_receivers(1000, &p, &n);
  const auto t0 = std::chrono::steady_clock::now();
  client->gather(info->scene_id(), p, n, every);
  const double per_receiver =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / 1000;

  // 150k receivers with a 300 ms deadline: the server must stop at the
  // deadline, not when the gather would have finished.
  floor_receivers(150000, &p, &n);
  std::string message_sink;
  client::ClientOptions hurried;
  hurried.call_deadline = std::chrono::milliseconds(300);
  const auto start = std::chrono::steady_clock::now();
  EXPECT_EQ(code_of([&] { PbgiClient(daemon->address(), hurried).gather(info->scene_id(), p, n, every); },
                    &message_sink),
            grpc::StatusCode::DEADLINE_EXCEEDED);
  const auto idle_after = wait_until_idle(std::chrono::seconds(10));
  const double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("cancel: full gather would take ~%.1f s; server idle %.2f s after the call began\n",
              per_receiver * 150000, total);
  EXPECT_LT(idle_after, std::chrono::milliseconds(1500)) << "the gather stopped at its deadline";
  EXPECT_LT(total, 0.5 * per_receiver * 150000) << "well before the work could have finished";

  // A client that cancels a RenderTiles stream after its first tile: the
  // remaining tiles are not rendered.
  const uint64_t completed_before = client->status().requests().completed();
  v1::RenderTilesRequest request;
  request.set_scene_id(info->scene_id());
  request.set_camera("/Camera");
  request.set_image_width(kSize);
  request.set_image_height(kSize);
  *request.mutable_options() = fast_gather();
  for (const v1::Tile& t : client::tile_grid(kSize, kSize, 8)) *request.add_tiles() = t;
  auto stub = v1::Pbgi::NewStub(grpc::CreateChannel(daemon->address(), grpc::InsecureChannelCredentials()));
  grpc::ClientContext context;
  auto reader = stub->RenderTiles(&context, request);
  v1::RenderTileResponse first;
  ASSERT_TRUE(reader->Read(&first));
  context.TryCancel();
  EXPECT_EQ(reader->Finish().error_code(), grpc::StatusCode::CANCELLED);
  EXPECT_LT(wait_until_idle(std::chrono::seconds(5)), std::chrono::seconds(1));
  const uint64_t rendered = client->status().requests().completed() - completed_before;
  EXPECT_LT(rendered, uint64_t(request.tiles_size()) / 2)
      << "of " << request.tiles_size() << " tiles";
  expect_serving();
}

TEST_F(Integration, OverloadIsRefusedWithARetryHintAndRetriedByTheClient) {
  // 10 simultaneous gathers (~0.1 s each) against 2 slots + 2 queue places.
  ASSERT_LT(wait_until_idle(std::chrono::seconds(10)), std::chrono::seconds(10));
  std::vector<Imath::V3f> p, n;
  floor_receivers(100, &p, &n);
  v1::GatherRequest request;
  request.set_scene_id(info->scene_id());
  request.set_positions(std::string(reinterpret_cast<const char*>(p.data()), p.size() * 12));
  request.set_normals(std::string(reinterpret_cast<const char*>(n.data()), n.size() * 12));
  *request.mutable_options() = fast_gather();
  auto stub = v1::Pbgi::NewStub(grpc::CreateChannel(daemon->address(), grpc::InsecureChannelCredentials()));
  std::atomic<int> ok{0}, refused{0}, hinted{0};
  std::vector<std::thread> threads;
  for (int i = 0; i < 10; ++i) {
    threads.emplace_back([&] {
      grpc::ClientContext context;
      v1::GatherResponse response;
      const grpc::Status s = stub->Gather(&context, request, &response);
      if (s.ok()) ++ok;
      if (s.error_code() == grpc::StatusCode::RESOURCE_EXHAUSTED) {
        ++refused;
        const auto& trailers = context.GetServerTrailingMetadata();
        const auto it = trailers.find("retry-after-ms");
        if (it != trailers.end() && std::stoi(std::string(it->second.data(), it->second.size())) > 0) {
          ++hinted;
        }
      }
    });
  }
  for (auto& t : threads) t.join();
  std::printf("overload: %d served, %d refused (%d with a hint)\n", ok.load(), refused.load(),
              hinted.load());
  EXPECT_GE(ok, 4) << "2 running + 2 queued are served";
  EXPECT_GE(refused, 1);
  EXPECT_EQ(hinted, refused) << "every refusal carries retry-after-ms";
  EXPECT_EQ(ok + refused, 10);
  EXPECT_GE(client->status().requests().rejected(), uint64_t(refused));

  // The client library waits as told and gets every one through.
  std::atomic<int> done{0};
  threads.clear();
  client::ClientOptions patient;
  patient.max_attempts = 50;
  PbgiClient retrying(daemon->address(), patient);
  for (int i = 0; i < 8; ++i) {
    threads.emplace_back([&] {
      if (retrying.gather(info->scene_id(), p, n, fast_gather()).irradiance.size() == p.size()) ++done;
    });
  }
  for (auto& t : threads) t.join();
  EXPECT_EQ(done, 8);
}

TEST_F(Integration, RenderTilesStreamsTilesLikeRenderTile) {
  v1::RenderTilesRequest request;
  request.set_scene_id(info->scene_id());
  request.set_camera("/Camera");
  request.set_image_width(kSize);
  request.set_image_height(kSize);
  *request.mutable_options() = fast_gather();
  // Three 16x16 tiles of the bottom row (floor, walls, boxes).
  std::vector<v1::Tile> grid = client::tile_grid(kSize, kSize, 16);
  grid.erase(grid.begin(), grid.end() - 3);
  for (const v1::Tile& t : grid) *request.add_tiles() = t;
  std::vector<client::TileImage> tiles;
  client->render_tiles(request, [&](client::TileImage&& t) { tiles.push_back(std::move(t)); });
  ASSERT_EQ(tiles.size(), grid.size());
  for (size_t i = 0; i < grid.size(); ++i) {
    EXPECT_EQ(tiles[i].tile.x0(), grid[i].x0()) << "in request order";
    EXPECT_EQ(tiles[i].tile.y0(), grid[i].y0());
  }

  v1::RenderTileRequest single;
  single.set_scene_id(info->scene_id());
  single.set_camera("/Camera");
  single.set_image_width(kSize);
  single.set_image_height(kSize);
  *single.mutable_tile() = grid[1];
  *single.mutable_options() = fast_gather();
  const client::TileImage alone = client->render_tile(single);
  ASSERT_EQ(alone.beauty.size(), tiles[1].beauty.size());
  double sum = 0, diff = 0;
  for (size_t i = 0; i < alone.beauty.size(); ++i) {
    sum += std::abs(alone.beauty[i]);
    diff += std::abs(alone.beauty[i] - tiles[1].beauty[i]);
  }
  EXPECT_GT(sum, 0.0);
  EXPECT_LE(diff, 1e-4 * sum) << "the same tile, the same image";
}

TEST_F(Integration, StatusAndUnload) {
  client->render_tile([&] {
    v1::RenderTileRequest r;
    r.set_scene_id(info->scene_id());
    r.set_camera("/Camera");
    r.set_image_width(kSize);
    r.set_image_height(kSize);
    r.mutable_tile()->set_x1(16);
    r.mutable_tile()->set_y1(16);
    *r.mutable_options() = fast_gather();
    return r;
  }());
  // Other tests may have opened scenes too (a plain run shares the daemon).
  v1::GetStatusResponse status = client->status();
  const int scenes_before = status.scenes_size();
  const v1::SceneStatus* ours = nullptr;
  for (const v1::SceneStatus& s : status.scenes()) {
    if (s.info().scene_id() == info->scene_id()) ours = &s;
  }
  ASSERT_NE(ours, nullptr);
  EXPECT_GE(ours->requests(), 1u);
  EXPECT_GT(ours->memory_bytes(), 0u);
  EXPECT_LT(ours->idle_seconds(), 5.0);
  EXPECT_GT(status.cache().misses(), 0u);
  EXPECT_GT(status.cache().bytes_read(), 0u);
  EXPECT_GT(status.cache().bytes_held(), 0u);
  // The page cache gets the 2 GiB memory budget less the request reserve
  // (64 MiB) and what the open scenes are charged (docs/memory-budget.md).
  uint64_t charged = 0;
  for (const v1::SceneStatus& s : status.scenes()) charged += s.memory_bytes();
  EXPECT_EQ(status.cache().budget_bytes(), (2ull << 30) - (64ull << 20) - charged);
  // The budget and who holds it; open scenes hold what they are charged.
  ASSERT_TRUE(status.has_memory());
  EXPECT_EQ(status.memory().budget_bytes(), 2ull << 30);
  EXPECT_EQ(status.memory().request_reserve_bytes(), 64ull << 20);
  EXPECT_EQ(status.memory().scenes_bytes(), charged);
  EXPECT_EQ(status.memory().reading_bytes(), 0u) << "no scene is being read";
  EXPECT_EQ(status.memory().builds_bytes(), 0u) << "no build runs";
  {
    std::string text;
    ASSERT_EQ(run_cli({"status", "--server", daemon->address()}, daemon->dir(), &text), 0) << text;
    EXPECT_NE(text.find("memory    budget 2048.0 MiB: requests 64.0 MiB, scenes "), std::string::npos) << text;
    EXPECT_NE(text.find(", reading 0.0 MiB, builds 0.0 MiB, page cache "), std::string::npos) << text;
    EXPECT_NE(text.find("(floor 32.0 MiB); 0 refused"), std::string::npos) << text;
  }
  EXPECT_GT(status.rss_bytes(), 10u << 20);
  EXPECT_EQ(status.requests().max_in_flight(), 2u);
  EXPECT_FALSE(status.version().empty());

  // Another scene (other build options), unloaded again.
  v1::BuildOptions other = small_build();
  other.set_target_surfels(3000);
  const v1::SceneInfo second = client->open_scene(kCornell.string(), other);
  EXPECT_EQ(client->status().scenes_size(), scenes_before + 1);
  client->unload_scene(second.scene_id());
  EXPECT_EQ(client->list_scenes().size(), size_t(scenes_before));
  std::string message;
  EXPECT_EQ(code_of([&] { client->unload_scene(second.scene_id()); }, &message),
            grpc::StatusCode::NOT_FOUND);
  EXPECT_EQ(code_of([&] { client->gather(second.scene_id(), {{0, 1, 0}}, {{0, 1, 0}}); }, &message),
            grpc::StatusCode::NOT_FOUND);
  expect_serving();
}

TEST_F(Integration, MalformedOversizedNanAndEmptyRequestsThenStillHealthy) {
  std::string message;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  // NaN position / normal.
  EXPECT_EQ(code_of([&] { client->gather(info->scene_id(), {{0, nan, 0}}, {{0, 1, 0}}); }, &message),
            grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(message.find("positions[0]"), std::string::npos) << message;
  EXPECT_EQ(code_of([&] { client->gather(info->scene_id(), {{0, 1, 0}, {0, 1, 0}}, {{0, 1, 0}, {nan, nan, nan}}); },
                    &message),
            grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(message.find("normals[1]"), std::string::npos) << message;
  // Zero normal; NaN option.
  EXPECT_EQ(code_of([&] { client->gather(info->scene_id(), {{0, 1, 0}}, {{0, 0, 0}}); }, &message),
            grpc::StatusCode::INVALID_ARGUMENT);
  v1::GatherOptions nan_options = fast_gather();
  nan_options.set_max_solid_angle(nan);
  EXPECT_EQ(code_of([&] { client->gather(info->scene_id(), {{0, 1, 0}}, {{0, 1, 0}}, nan_options); },
                    &message),
            grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(message.find("max_solid_angle"), std::string::npos) << message;

  // Empty: no receivers, no scene id, an empty RenderTiles.
  EXPECT_EQ(code_of([&] { client->gather(info->scene_id(), {}, {}); }, &message),
            grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(code_of([&] { client->gather("", {{0, 1, 0}}, {{0, 1, 0}}); }, &message),
            grpc::StatusCode::INVALID_ARGUMENT);
  v1::RenderTilesRequest no_tiles;
  no_tiles.set_scene_id(info->scene_id());
  no_tiles.set_camera("/Camera");
  no_tiles.set_image_width(kSize);
  no_tiles.set_image_height(kSize);
  EXPECT_EQ(code_of([&] { client->render_tiles(no_tiles, {}); }, &message),
            grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(code_of([&] { client->open_scene(""); }, &message), grpc::StatusCode::INVALID_ARGUMENT);

  // Over the receiver limit (200000 in the config), and over the message
  // size limit (8 MiB): refused before any work.
  std::vector<Imath::V3f> p, n;
  floor_receivers(200001, &p, &n);
  EXPECT_EQ(code_of([&] { client->gather(info->scene_id(), p, n); }, &message),
            grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(message.find("limit of 200000"), std::string::npos) << message;
  floor_receivers(400000, &p, &n);
  EXPECT_EQ(code_of([&] { client->gather(info->scene_id(), p, n); }, &message),
            grpc::StatusCode::RESOURCE_EXHAUSTED);

  // Garbage glossy arrays.
  v1::GatherRequest glossy;
  glossy.set_scene_id(info->scene_id());
  const float up[3] = {0, 1, 0};
  glossy.set_positions(std::string(reinterpret_cast<const char*>(up), 12));
  glossy.set_normals(std::string(reinterpret_cast<const char*>(up), 12));
  glossy.set_roughness(std::string(reinterpret_cast<const char*>(&nan), 4));
  EXPECT_EQ(code_of([&] { client->gather_raw(glossy); }, &message), grpc::StatusCode::INVALID_ARGUMENT);
  glossy.set_roughness(std::string(7, '\0'));
  EXPECT_EQ(code_of([&] { client->gather_raw(glossy); }, &message), grpc::StatusCode::INVALID_ARGUMENT);
  // Valid glossy arrays are accepted (and do not change the diffuse result).
  const float half = 0.5f;
  glossy.set_roughness(std::string(reinterpret_cast<const char*>(&half), 4));
  glossy.set_view_directions(std::string(reinterpret_cast<const char*>(up), 12));
  EXPECT_EQ(client->gather_raw(glossy).irradiance().size(), 12u);

  // After all of it: healthy, and a tile renders finite and lit.
  EXPECT_TRUE(healthy());
  v1::RenderTileRequest tile;
  tile.set_scene_id(info->scene_id());
  tile.set_camera("/Camera");
  tile.set_image_width(kSize);
  tile.set_image_height(kSize);
  tile.mutable_tile()->set_x0(16);
  tile.mutable_tile()->set_y0(32);
  tile.mutable_tile()->set_x1(48);
  tile.mutable_tile()->set_y1(64);
  *tile.mutable_options() = fast_gather();
  const client::TileImage image = client->render_tile(tile);
  double sum = 0;
  for (float v : image.beauty) {
    ASSERT_TRUE(std::isfinite(v));
    sum += v;
  }
  EXPECT_GT(sum, 0.0);
}

// Runs the pbgi CLI with `args`; its exit status, stdout + stderr in *text.

TEST_F(Integration, CliStatusAndResumedRender) {
  const fs::path dir = daemon->dir() / "cli-resume";
  fs::create_directories(dir);
  std::string text;
  ASSERT_EQ(run_cli({"status", "--server", daemon->address()}, dir, &text), 0) << text;
  EXPECT_NE(text.find(info->scene_id()), std::string::npos) << text;
  EXPECT_NE(text.find("cache"), std::string::npos) << text;
  ASSERT_EQ(run_cli({"status", "--server", daemon->address(), "--json"}, dir, &text), 0) << text;
  EXPECT_NE(text.find("\"scenes\""), std::string::npos) << text;

  // Options the daemon cannot serve are refused by name, not ignored.
  const std::vector<std::string> common = {
      "render", kCornell.string(), "--server", daemon->address(), "--width", "32",
      "--height", "24", "--tile", "8", "--jobs", "1", "--light-samples", "4",
      "--target-surfels", "20000", "--build-light-samples", "4", "--no-png", "--quiet"};
  auto with = [&](std::vector<std::string> extra) {
    std::vector<std::string> v = common;
    v.insert(v.end(), extra.begin(), extra.end());
    return v;
  };
  EXPECT_NE(run_cli(with({"--payload", "wavelet", "--out", (dir / "x.exr").string()}), dir, &text), 0);
  EXPECT_NE(text.find("--payload wavelet"), std::string::npos) << text;
  EXPECT_NE(run_cli(with({"--bounces", "5", "--out", (dir / "x.exr").string()}), dir, &text), 0);
  EXPECT_NE(text.find("--bounces"), std::string::npos) << text;

  // Interrupted after 3 of 12 tiles, then resumed: only 9 are rendered and
  // the image equals an uninterrupted render.
  const fs::path out = dir / "resumed.exr";
  EXPECT_EQ(run_cli(with({"--out", out.string(), "--max-new-tiles", "3"}), dir, &text), 3) << text;
  EXPECT_TRUE(fs::exists(out.string() + ".partial")) << text;
  EXPECT_FALSE(fs::exists(out));
  ASSERT_EQ(run_cli(with({"--out", out.string(), "--resume"}), dir, &text), 0) << text;
  EXPECT_NE(text.find("12 tiles, 3 resumed"), std::string::npos) << text;
  EXPECT_FALSE(fs::exists(out.string() + ".partial")) << "the sidecar is removed when done";

  const fs::path whole = dir / "whole.exr";
  ASSERT_EQ(run_cli(with({"--out", whole.string()}), dir, &text), 0) << text;
  const image::ExrImage a = image::read_exr(out.string()), b = image::read_exr(whole.string());
  double sum = 0, diff = 0;
  for (const char* channel : {"R", "G", "B", "indirect.G", "ao.Y"}) {
    const auto& ca = a.channel(channel);
    const auto& cb = b.channel(channel);
    ASSERT_EQ(ca.size(), cb.size());
    for (size_t i = 0; i < ca.size(); ++i) {
      sum += std::abs(cb[i]);
      diff += std::abs(ca[i] - cb[i]);
    }
  }
  EXPECT_GT(sum, 0.0);
  EXPECT_LE(diff, 1e-4 * sum) << "resumed and uninterrupted renders agree";

  // A sidecar of another render is not mixed in.
  EXPECT_EQ(run_cli(with({"--out", out.string(), "--max-new-tiles", "1"}), dir, &text), 3);
  std::vector<std::string> other = with({"--out", out.string(), "--resume"});
  other[5] = "40";  // --width
  EXPECT_NE(run_cli(other, dir, &text), 0);
  EXPECT_NE(text.find("another render"), std::string::npos) << text;
}

}  // namespace
}  // namespace pbgi
