// render_frame: the tile grid covers the image exactly, tiles land where
// they belong whatever order they complete in, the first error stops it.
#include "client/lib/frame_renderer.h"
#include "tests/client/lib/fake_pbgi_server.h"

#include <gtest/gtest.h>

namespace pbgi::client {
namespace {

using testing::FakePbgiServer;

TEST(TileGrid, CoversImageWithEdgeTiles) {
  const auto tiles = tile_grid(70, 33, 32);
  ASSERT_EQ(tiles.size(), 3u * 2u);
  EXPECT_EQ(tiles[2].x0(), 64u);
  EXPECT_EQ(tiles[2].x1(), 70u);
  EXPECT_EQ(tiles[5].y0(), 32u);
  EXPECT_EQ(tiles[5].y1(), 33u);
  uint64_t area = 0;
  for (const auto& t : tiles) area += uint64_t(t.x1() - t.x0()) * (t.y1() - t.y0());
  EXPECT_EQ(area, 70u * 33u);
  EXPECT_TRUE(tile_grid(10, 10, 0).empty());
}

// The fake encodes each pixel's image coordinates in its AOVs.
grpc::Status coordinate_tile(const v1::RenderTileRequest* r, v1::RenderTileResponse* out) {
  const v1::Tile& t = r->tile();
  std::vector<float> rgb, y;
  for (uint32_t py = t.y0(); py < t.y1(); ++py) {
    for (uint32_t px = t.x0(); px < t.x1(); ++px) {
      rgb.insert(rgb.end(), {float(px), float(py), 1.f});
      y.push_back(float(px + 1000 * py));
    }
  }
  auto bytes = [](const std::vector<float>& v) {
    return std::string(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(float));
  };
  *out->mutable_tile() = t;
  out->set_beauty(bytes(rgb));
  out->set_direct(bytes(rgb));
  out->set_indirect(bytes(rgb));
  out->set_albedo(bytes(rgb));
  out->set_ao(bytes(y));
  out->mutable_stats()->set_nodes_visited(1);
  return grpc::Status::OK;
}

TEST(RenderFrame, AssemblesTilesInPlace) {
  FakePbgiServer server;
  server.service.render = [](auto*, const v1::RenderTileRequest* r, v1::RenderTileResponse* out) {
    EXPECT_EQ(r->camera(), "/Camera");
    EXPECT_EQ(r->image_width(), 37u);
    EXPECT_EQ(r->options().light_samples(), 4u);
    return coordinate_tile(r, out);
  };
  PbgiClient client(server.address());
  FrameRequest request;
  request.scene_id = std::string("scene");
  request.camera = "/Camera";
  request.width = 37;
  request.height = 21;
  request.tile_size = 8;
  request.jobs = 3;
  request.options.set_light_samples(4);
  uint32_t last_done = 0, calls = 0;
  const Frame frame = render_frame(client, request, [&](uint32_t done, uint32_t total) {
    EXPECT_EQ(done, last_done + 1);
    EXPECT_EQ(total, 5u * 3u);
    last_done = done;
    ++calls;
  });
  EXPECT_EQ(calls, 15u);
  EXPECT_EQ(frame.tiles, 15u);
  EXPECT_EQ(frame.stats.nodes_visited(), 15u);
  for (uint32_t y = 0; y < 21; ++y) {
    for (uint32_t x = 0; x < 37; ++x) {
      const size_t i = size_t(y) * 37 + x;
      ASSERT_EQ(frame.beauty[3 * i], float(x));
      ASSERT_EQ(frame.indirect[3 * i + 1], float(y));
      ASSERT_EQ(frame.ao[i], float(x + 1000 * y));
    }
  }
}

TEST(RenderFrame, FirstErrorStopsTheFrame) {
  FakePbgiServer server;
  server.service.render = [](auto*, const v1::RenderTileRequest* r, v1::RenderTileResponse* out) {
    if (r->tile().x0() == 8 && r->tile().y0() == 0) {
      return grpc::Status(grpc::StatusCode::INTERNAL, "tile [8,16) broke");
    }
    return coordinate_tile(r, out);
  };
  PbgiClient client(server.address());
  FrameRequest request;
  request.scene_id = std::string("scene");
  request.camera = "/Camera";
  request.width = 64;
  request.height = 64;
  request.tile_size = 8;
  request.jobs = 1;  // sequential: the error comes at the second tile
  try {
    render_frame(client, request);
    FAIL() << "expected RpcError";
  } catch (const RpcError& e) {
    EXPECT_EQ(e.code(), grpc::StatusCode::INTERNAL);
    EXPECT_NE(e.server_message().find("tile [8,16)"), std::string::npos);
  }
  EXPECT_EQ(server.service.render_calls, 2) << "no tile after the failure";
}

TEST(RenderFrame, RejectsEmptyRequests) {
  FakePbgiServer server;
  PbgiClient client(server.address());
  FrameRequest request;
  request.width = 0;
  request.height = 4;
  EXPECT_THROW(render_frame(client, request), InvalidArgument);
}

}  // namespace
}  // namespace pbgi::client
