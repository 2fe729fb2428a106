// Renders a whole image through RenderTile: the image is cut into tiles,
// `jobs` requests are kept in flight, tiles are assembled into full-frame
// AOV buffers as they arrive.
#pragma once

#include "client/lib/pbgi_client.h"

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace pbgi::client {

struct FrameRequest {
  std::string scene_id;
  std::string camera;               // camera prim path
  uint32_t width = 0, height = 0;
  uint32_t tile_size = 32;          // pixels per tile side (edge tiles are smaller)
  unsigned jobs = 4;                // RenderTile requests in flight
  v1::GatherOptions options;        // unset fields: the daemon's defaults
  // Tiles already rendered (a resumed render reads them back): copied into
  // the frame and not requested again. Each must be a tile of the grid.
  std::vector<TileImage> done_tiles;
  // Called with each newly rendered tile (calls are serialized), e.g. to
  // record it for a later resume.
  std::function<void(const TileImage& tile)> on_tile;
};

// Full-frame AOVs, row-major, y down from the top; rgb layers interleaved.
struct Frame {
  uint32_t width = 0, height = 0;
  std::vector<float> beauty, direct, indirect, albedo;  // 3 floats per pixel
  std::vector<float> ao;                                // 1 float per pixel
  v1::GatherStats stats;     // summed over tiles (seconds: sum of server time)
  uint32_t tiles = 0;
  double seconds = 0;        // wall clock of the whole frame
};

// Row-major tiles covering width x height.
std::vector<v1::Tile> tile_grid(uint32_t width, uint32_t height, uint32_t tile_size);

// Pieces of render_frame() that other frame assemblers (client/stress's
// replicated frame) share, so that every assembler fills a Frame alike.
// A width x height frame with every AOV zeroed (no tiles, no stats).
Frame blank_frame(uint32_t width, uint32_t height);
// Copies `tile`'s AOVs into `frame` at `where`, a tile of the frame's grid
// whose size is the tile's (not checked). Tiles are disjoint, so
// concurrent calls for different tiles need no lock.
void place_tile(const TileImage& tile, const v1::Tile& where, Frame& frame);
// Adds every counter of a tile's statistics to `total`.
void add_tile_stats(const v1::GatherStats& tile, v1::GatherStats& total);

// Called after each tile, from the thread that received it (calls are
// serialized): tiles done, total.
using TileProgress = std::function<void(uint32_t done, uint32_t total)>;

// Throws InvalidArgument for an empty image, tile size or jobs = 0 or a
// done tile that is not one of the grid, and the first RpcError of any
// tile (the remaining tiles are abandoned). Progress counts done tiles too.
Frame render_frame(PbgiClient& client, const FrameRequest& request,
                   const TileProgress& progress = {});

}  // namespace pbgi::client
