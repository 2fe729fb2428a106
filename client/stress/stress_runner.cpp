#include "client/stress/stress_runner.h"

#include "client/lib/frame_renderer.h"
#include "client/lib/pbgi_client.h"
#include "common/errors.h"

#include <fmt/format.h>

#include <atomic>
#include <memory>
#include <mutex>
#include <random>
#include <thread>

namespace pbgi::stress {
namespace {

using Clock = std::chrono::steady_clock;
constexpr size_t kMaxErrorSamples = 8;

// What one client thread saw; merged after the run (no shared counters on
// the hot path beyond two progress atomics).
struct ClientTally {
  uint64_t requests = 0, ok = 0, pixels = 0;
  std::map<std::string, uint64_t> errors_by_code;
  std::vector<std::string> error_samples;
  std::vector<double> latencies_ms;
};

}  // namespace

StressResult run_stress(const StressOptions& options, const StressProgress& progress) {
  if (options.servers.empty()) throw InvalidArgument("stress: no server given");
  if (options.clients == 0) throw InvalidArgument("stress: clients must be at least 1");
  if (options.width == 0 || options.height == 0 || options.tile == 0) {
    throw InvalidArgument(fmt::format("stress: image {}x{} with tile {} is empty", options.width,
                                      options.height, options.tile));
  }
  if (!(options.duration.count() > 0)) throw InvalidArgument("stress: duration must be positive");

  client::ClientOptions client_options;
  client_options.call_deadline = options.call_deadline;
  client_options.max_attempts = std::max(1, options.max_attempts);

  // 1. Open (or join) the scene on every server, before the clock starts.
  StressResult result;
  result.clients = options.clients;
  result.requests_per_server.assign(options.servers.size(), 0);
  for (const std::string& server : options.servers) {
    client::PbgiClient opener(client::normalize_address(server), client_options);
    const v1::SceneInfo info =
        opener.open_scene(client::scene_request_path(options.scene), options.build);
    if (result.camera.empty()) result.camera = client::camera_for(info, options.camera);
    result.scene_ids.push_back(info.scene_id());
  }
  const std::vector<v1::Tile> grid = client::tile_grid(options.width, options.height, options.tile);

  // 2. The load: each client keeps one RenderTile in flight until the end.
  std::vector<ClientTally> tallies(options.clients);
  std::atomic<uint64_t> requests{0}, errors{0};
  const auto start = Clock::now();
  const auto end = start + std::chrono::duration_cast<Clock::duration>(options.duration);
  std::vector<std::thread> threads;
  for (unsigned c = 0; c < options.clients; ++c) {
    threads.emplace_back([&, c] {
      const size_t server = c % options.servers.size();
      client::PbgiClient client(client::normalize_address(options.servers[server]), client_options);
      std::mt19937_64 rng(options.seed + c);
      std::uniform_int_distribution<size_t> pick(0, grid.size() - 1);
      v1::RenderTileRequest request;
      request.set_scene_id(result.scene_ids[server]);
      request.set_camera(result.camera);
      request.set_image_width(options.width);
      request.set_image_height(options.height);
      *request.mutable_options() = options.gather;
      ClientTally& tally = tallies[c];
      while (Clock::now() < end) {
        *request.mutable_tile() = grid[pick(rng)];
        const auto t0 = Clock::now();
        std::string code, message;
        try {
          const client::TileImage tile = client.render_tile(request);
          tally.latencies_ms.push_back(
              std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
          ++tally.ok;
          tally.pixels += uint64_t(tile.width()) * tile.height();
        } catch (const client::RpcError& e) {
          code = client::status_code_name(e.code());
          message = e.what();
        } catch (const std::exception& e) {
          code = "CLIENT";
          message = e.what();
        }
        ++tally.requests;
        requests.fetch_add(1, std::memory_order_relaxed);
        if (!code.empty()) {
          ++tally.errors_by_code[code];
          errors.fetch_add(1, std::memory_order_relaxed);
          if (tally.error_samples.size() < kMaxErrorSamples) {
            tally.error_samples.push_back(fmt::format("client {} ({}): {}", c,
                                                      options.servers[server], message));
          }
        }
      }
    });
  }
  // 3. Progress once a second while the clients run.
  while (Clock::now() < end) {
    std::this_thread::sleep_until(std::min(end, Clock::now() + std::chrono::seconds(1)));
    if (progress) {
      progress(std::chrono::duration<double>(Clock::now() - start).count(), requests.load(),
               errors.load());
    }
  }
  for (std::thread& t : threads) t.join();
  result.seconds = std::chrono::duration<double>(Clock::now() - start).count();

  // 4. Merge.
  std::vector<double> latencies;
  for (unsigned c = 0; c < options.clients; ++c) {
    const ClientTally& t = tallies[c];
    result.requests += t.requests;
    result.ok += t.ok;
    result.pixels += t.pixels;
    result.requests_per_server[c % options.servers.size()] += t.requests;
    for (const auto& [code, n] : t.errors_by_code) result.errors_by_code[code] += n;
    for (const std::string& s : t.error_samples) {
      if (result.error_samples.size() < kMaxErrorSamples) result.error_samples.push_back(s);
    }
    latencies.insert(latencies.end(), t.latencies_ms.begin(), t.latencies_ms.end());
  }
  result.latency = summarize_latencies(latencies);
  return result;
}

}  // namespace pbgi::stress
