// End to end: pbgid as a child process on a temporary unix socket, driven
// through the client library and the pbgi CLI on scenes/cornell.usda.
//   - a 64x64 render tile by tile: finite AOVs, colour bleeding from the
//     red and green walls onto the floor, a ceiling lit only indirectly;
//   - the same physics through explicit Gather receivers;
//   - bad requests get NOT_FOUND / PERMISSION_DENIED / INVALID_ARGUMENT /
//     OUT_OF_RANGE and the daemon keeps serving;
//   - `pbgi render` writes a readable EXR and PNG;
//   - SIGTERM stops the daemon cleanly and removes its socket.
#include "client/image/exr_image.h"
#include "client/lib/frame_renderer.h"
#include "client/lib/pbgi_client.h"
#include "tests/integration/daemon_process.h"

#include <gtest/gtest.h>

#include <cmath>
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
    daemon = new testing::DaemonProcess(
        kBinaryDir / "bin" / "pbgid",
        {"--scene-root", (kSourceDir / "scenes").string(), "--log-level", "info"});
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
  EXPECT_EQ(out.stats.receivers(), positions.size());
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
  const std::vector<std::string> argv = {
      (kBinaryDir / "bin" / "pbgi").string(), "render", kCornell.string(),
      "--server", daemon->address(), "--camera", "/Camera", "--width", "32", "--height", "24",
      "--tile", "16", "--jobs", "2", "--out", out.string(), "--light-samples", "4",
      "--target-surfels", "20000", "--build-light-samples", "4"};
  const pid_t pid = testing::spawn(argv, daemon->dir() / "cli.out", daemon->dir() / "cli.err");
  const int status = testing::wait_for_exit(pid, std::chrono::seconds(60));
  std::ifstream cli_out(daemon->dir() / "cli.out"), cli_err(daemon->dir() / "cli.err");
  std::stringstream text;
  text << cli_out.rdbuf() << cli_err.rdbuf();
  ASSERT_EQ(status, 0) << text.str();
  EXPECT_NE(text.str().find(out.string()), std::string::npos) << "prints the paths\n" << text.str();
  EXPECT_NE(text.str().find("total"), std::string::npos) << "prints timings\n" << text.str();

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

}  // namespace
}  // namespace pbgi
