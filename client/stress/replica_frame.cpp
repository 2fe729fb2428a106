#include "client/stress/replica_frame.h"

#include "common/errors.h"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <exception>
#include <mutex>
#include <thread>

namespace pbgi::stress {

ReplicaFrame render_frame_replicated(const std::vector<client::PbgiClient*>& replicas,
                                     const client::FrameRequest& request) {
  if (replicas.empty()) throw InvalidArgument("render_frame_replicated: no replica");
  if (request.width == 0 || request.height == 0 || request.tile_size == 0) {
    throw InvalidArgument(fmt::format("render_frame_replicated: image {}x{} tile {} is empty",
                                      request.width, request.height, request.tile_size));
  }
  const auto start = std::chrono::steady_clock::now();
  const size_t n = replicas.size();
  ReplicaFrame out;
  out.frame = client::blank_frame(request.width, request.height);
  client::Frame& frame = out.frame;
  out.tiles_per_replica.assign(n, 0);

  const std::vector<v1::Tile> tiles = client::tile_grid(request.width, request.height, request.tile_size);
  frame.tiles = static_cast<uint32_t>(tiles.size());
  // Replica r's tiles are r, r + n, r + 2n, ...; its workers take them in order.
  std::vector<std::atomic<size_t>> next(n);
  for (size_t r = 0; r < n; ++r) next[r] = r;
  std::atomic<bool> failed{false};
  std::mutex mutex;  // guards the frame's stats, the counters and `error`
  std::exception_ptr error;

  auto worker = [&](size_t home) {
    v1::RenderTileRequest tile_request;
    tile_request.set_scene_id(request.scene_id);
    tile_request.set_camera(request.camera);
    tile_request.set_image_width(request.width);
    tile_request.set_image_height(request.height);
    *tile_request.mutable_options() = request.options;
    for (;;) {
      if (failed) return;
      const size_t i = next[home].fetch_add(n);
      if (i >= tiles.size()) return;
      *tile_request.mutable_tile() = tiles[i];
      // Home replica first, then the others in order while they are unavailable.
      for (size_t attempt = 0; attempt < n; ++attempt) {
        const size_t r = (home + attempt) % n;
        try {
          const client::TileImage tile = replicas[r]->render_tile(tile_request);
          client::place_tile(tile, tiles[i], frame);
          std::lock_guard lock(mutex);
          ++out.tiles_per_replica[r];
          if (attempt > 0) ++out.failovers;
          client::add_tile_stats(tile.stats, frame.stats);
          break;
        } catch (const client::RpcError& e) {
          if (e.code() == grpc::StatusCode::UNAVAILABLE && attempt + 1 < n) continue;
          std::lock_guard lock(mutex);
          if (!error) error = std::current_exception();
          failed = true;
          return;
        } catch (...) {
          std::lock_guard lock(mutex);
          if (!error) error = std::current_exception();
          failed = true;
          return;
        }
      }
    }
  };
  const size_t jobs_per_replica = std::max<size_t>(1, (std::max(1u, request.jobs) + n - 1) / n);
  std::vector<std::thread> threads;
  for (size_t r = 0; r < n; ++r) {
    for (size_t j = 0; j < jobs_per_replica; ++j) threads.emplace_back(worker, r);
  }
  for (std::thread& t : threads) t.join();
  if (error) std::rethrow_exception(error);
  frame.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

}  // namespace pbgi::stress
