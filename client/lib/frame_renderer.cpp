#include "client/lib/frame_renderer.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <exception>
#include <mutex>
#include <thread>

namespace pbgi::client {
namespace {

// Copies a tile's rows of `channels` floats per pixel into the frame.
void blit(const std::vector<float>& tile_values, const v1::Tile& tile, uint32_t frame_width,
          int channels, std::vector<float>& frame_values) {
  const uint32_t w = tile.x1() - tile.x0();
  for (uint32_t y = tile.y0(); y < tile.y1(); ++y) {
    const float* src = tile_values.data() + size_t(y - tile.y0()) * w * channels;
    float* dst = frame_values.data() + (size_t(y) * frame_width + tile.x0()) * channels;
    std::copy(src, src + size_t(w) * channels, dst);
  }
}

}  // namespace

Frame blank_frame(uint32_t width, uint32_t height) {
  Frame frame;
  frame.width = width;
  frame.height = height;
  const size_t pixels = size_t(width) * height;
  frame.beauty.assign(3 * pixels, 0.f);
  frame.direct.assign(3 * pixels, 0.f);
  frame.indirect.assign(3 * pixels, 0.f);
  frame.albedo.assign(3 * pixels, 0.f);
  frame.ao.assign(pixels, 0.f);
  return frame;
}

void place_tile(const TileImage& tile, const v1::Tile& where, Frame& frame) {
  blit(tile.beauty, where, frame.width, 3, frame.beauty);
  blit(tile.direct, where, frame.width, 3, frame.direct);
  blit(tile.indirect, where, frame.width, 3, frame.indirect);
  blit(tile.albedo, where, frame.width, 3, frame.albedo);
  blit(tile.ao, where, frame.width, 1, frame.ao);
}

void add_tile_stats(const v1::GatherStats& s, v1::GatherStats& total) {
  total.set_receivers(total.receivers() + s.receivers());
  total.set_nodes_visited(total.nodes_visited() + s.nodes_visited());
  total.set_nodes_rasterized(total.nodes_rasterized() + s.nodes_rasterized());
  total.set_surfels_raycast(total.surfels_raycast() + s.surfels_raycast());
  total.set_seconds(total.seconds() + s.seconds());
  total.set_camera_samples(total.camera_samples() + s.camera_samples());
  total.set_pixels(total.pixels() + s.pixels());
}

std::vector<v1::Tile> tile_grid(uint32_t width, uint32_t height, uint32_t tile_size) {
  std::vector<v1::Tile> tiles;
  if (tile_size == 0) return tiles;
  for (uint32_t y = 0; y < height; y += tile_size) {
    for (uint32_t x = 0; x < width; x += tile_size) {
      v1::Tile& t = tiles.emplace_back();
      t.set_x0(x);
      t.set_y0(y);
      t.set_x1(std::min(width, x + tile_size));
      t.set_y1(std::min(height, y + tile_size));
    }
  }
  return tiles;
}

Frame render_frame(PbgiClient& client, const FrameRequest& request, const TileProgress& progress) {
  if (request.width == 0 || request.height == 0) {
    throw InvalidArgument("render_frame: image size " + std::to_string(request.width) + "x" +
                          std::to_string(request.height) + " is empty");
  }
  if (request.tile_size == 0) throw InvalidArgument("render_frame: tile size is 0");
  if (request.jobs == 0) throw InvalidArgument("render_frame: jobs is 0");
  const auto start = std::chrono::steady_clock::now();

  Frame frame = blank_frame(request.width, request.height);

  const std::vector<v1::Tile> grid = tile_grid(request.width, request.height, request.tile_size);
  const uint32_t total = static_cast<uint32_t>(grid.size());

  // Tiles rendered before: into the frame, off the list.
  auto same = [](const v1::Tile& a, const v1::Tile& b) {
    return a.x0() == b.x0() && a.y0() == b.y0() && a.x1() == b.x1() && a.y1() == b.y1();
  };
  std::vector<bool> skip(grid.size(), false);
  for (const TileImage& t : request.done_tiles) {
    const auto it = std::find_if(grid.begin(), grid.end(), [&](const v1::Tile& g) { return same(g, t.tile); });
    const size_t pixels = size_t(t.width()) * t.height();
    if (it == grid.end() || t.beauty.size() != 3 * pixels || t.direct.size() != 3 * pixels ||
        t.indirect.size() != 3 * pixels || t.albedo.size() != 3 * pixels || t.ao.size() != pixels) {
      throw InvalidArgument("render_frame: a done tile is not a tile of the " +
                            std::to_string(request.width) + "x" + std::to_string(request.height) +
                            " grid of " + std::to_string(request.tile_size) + " or has wrong sizes");
    }
    place_tile(t, *it, frame);
    skip[size_t(it - grid.begin())] = true;
  }
  std::vector<v1::Tile> tiles;
  for (size_t i = 0; i < grid.size(); ++i) {
    if (!skip[i]) tiles.push_back(grid[i]);
  }
  std::atomic<size_t> next{0};
  std::atomic<bool> failed{false};
  std::mutex mutex;  // guards done, stats, error, progress calls
  uint32_t done = total - static_cast<uint32_t>(tiles.size());
  std::exception_ptr error;
  if (progress && done > 0) progress(done, total);

  // Each worker keeps one request in flight; tiles go to whoever is free.
  auto worker = [&] {
    v1::RenderTileRequest tile_request;
    tile_request.set_scene_id(request.scene_id);
    tile_request.set_camera(request.camera);
    tile_request.set_image_width(request.width);
    tile_request.set_image_height(request.height);
    *tile_request.mutable_options() = request.options;
    for (size_t i = next++; i < tiles.size() && !failed; i = next++) {
      try {
        *tile_request.mutable_tile() = tiles[i];
        const TileImage tile = client.render_tile(tile_request);
        // Tiles are disjoint: the copies need no lock.
        place_tile(tile, tiles[i], frame);
        std::lock_guard lock(mutex);
        add_tile_stats(tile.stats, frame.stats);
        if (request.on_tile) request.on_tile(tile);
        ++done;
        if (progress) progress(done, total);
      } catch (...) {
        std::lock_guard lock(mutex);
        if (!error) error = std::current_exception();
        failed = true;
      }
    }
  };
  const unsigned threads = static_cast<unsigned>(std::min<size_t>(request.jobs, tiles.size()));
  std::vector<std::thread> workers;
  workers.reserve(threads);
  for (unsigned t = 0; t < threads; ++t) workers.emplace_back(worker);
  for (std::thread& t : workers) t.join();
  if (error) std::rethrow_exception(error);

  frame.tiles = total;
  frame.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return frame;
}

}  // namespace pbgi::client
