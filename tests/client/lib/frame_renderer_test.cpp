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

using testing::coordinate_tile;  // AOVs encode each pixel's coordinates

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

// The pieces every frame assembler shares (render_frame, client/stress's
// replicated frame): a tile lands at its place in each AOV, and every
// statistic is summed.
TEST(FramePieces, PlaceTileAndSumEveryStatistic) {
  Frame frame = blank_frame(5, 4);
  ASSERT_EQ(frame.beauty.size(), 60u);
  ASSERT_EQ(frame.ao.size(), 20u);
  TileImage tile;
  tile.tile.set_x0(3);
  tile.tile.set_y0(1);
  tile.tile.set_x1(5);
  tile.tile.set_y1(3);
  for (float v = 0; v < 4; ++v) {
    tile.beauty.insert(tile.beauty.end(), {v, v, v});
    tile.direct.insert(tile.direct.end(), {v + 10, 0, 0});
    tile.indirect.insert(tile.indirect.end(), {0, v + 20, 0});
    tile.albedo.insert(tile.albedo.end(), {0, 0, v + 30});
    tile.ao.push_back(v + 40);
  }
  place_tile(tile, tile.tile, frame);
  // Tile pixel (1, 1) is frame pixel (4, 2).
  const size_t i = 2 * 5 + 4;
  EXPECT_EQ(frame.beauty[3 * i], 3.f);
  EXPECT_EQ(frame.direct[3 * i], 13.f);
  EXPECT_EQ(frame.indirect[3 * i + 1], 23.f);
  EXPECT_EQ(frame.albedo[3 * i + 2], 33.f);
  EXPECT_EQ(frame.ao[i], 43.f);
  EXPECT_EQ(frame.ao[1 * 5 + 3], 40.f);
  EXPECT_EQ(frame.ao[0], 0.f);  // outside the tile: untouched
  EXPECT_EQ(frame.ao[2 * 5 + 2], 0.f);

  v1::GatherStats s;
  s.set_receivers(1);
  s.set_nodes_visited(2);
  s.set_nodes_rasterized(3);
  s.set_surfels_raycast(4);
  s.set_seconds(0.5);
  s.set_camera_samples(6);
  s.set_pixels(7);
  v1::GatherStats total;
  add_tile_stats(s, total);
  add_tile_stats(s, total);
  EXPECT_EQ(total.receivers(), 2u);
  EXPECT_EQ(total.nodes_visited(), 4u);
  EXPECT_EQ(total.nodes_rasterized(), 6u);
  EXPECT_EQ(total.surfels_raycast(), 8u);
  EXPECT_DOUBLE_EQ(total.seconds(), 1.0);
  EXPECT_EQ(total.camera_samples(), 12u);
  EXPECT_EQ(total.pixels(), 14u);
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
