// C++ client of pbgid: one channel, typed calls with per-call deadlines and
// retries on UNAVAILABLE (daemon starting or restarting) with exponential
// backoff. Failures throw RpcError (a pbgi::Error) with the server's message.
//
// Thread-safe: calls may be made concurrently from many threads (the CLI
// keeps several RenderTile requests in flight this way).
#pragma once

#include "client/lib/rpc_error.h"
#include "pbgi/v1/pbgi.grpc.pb.h"

#include <Imath/ImathColor.h>
#include <Imath/ImathVec.h>

#include <chrono>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace pbgi::client {

struct ClientOptions {
  // Deadline of each Gather / RenderTile / ListScenes call, retries included.
  std::chrono::milliseconds call_deadline{std::chrono::minutes(5)};
  // Deadline of OpenScene (a first open builds the tree: minutes for big scenes).
  std::chrono::milliseconds open_deadline{std::chrono::hours(1)};
  // Attempts per call while the daemon answers UNAVAILABLE (1 = no retry).
  int max_attempts = 5;
  // Backoff between attempts: initial, doubling up to max, with jitter.
  std::chrono::milliseconds initial_backoff{100};
  std::chrono::milliseconds max_backoff{2000};
  // Largest request the client sends (responses are not limited).
  int max_send_message_bytes = 64 << 20;
};

using OpenProgress = std::function<void(const std::string& stage, float fraction)>;

// One rendered tile, AOVs row-major as in RenderTileResponse.
struct TileImage {
  v1::Tile tile;
  std::vector<float> beauty, direct, indirect, albedo;  // rgb
  std::vector<float> ao;                                // y
  v1::GatherStats stats;
  uint32_t width() const { return tile.x1() - tile.x0(); }
  uint32_t height() const { return tile.y1() - tile.y0(); }
};

struct GatherOutput {
  std::vector<Imath::C3f> irradiance;
  std::vector<float> ao;
  v1::GatherStats stats;
};

class PbgiClient {
 public:
  // `address`: "unix:PATH" or "HOST:PORT" (any gRPC target). Connecting is
  // lazy: an unreachable daemon shows up as UNAVAILABLE on the first call.
  explicit PbgiClient(const std::string& address, ClientOptions options = {});
  ~PbgiClient();

  const std::string& address() const { return address_; }

  // Opens (or joins) a scene; `progress` sees each stage report. Returns
  // the final SceneInfo. Retried on UNAVAILABLE only before any event came.
  v1::SceneInfo open_scene(const std::string& scene_path, const v1::BuildOptions& build = {},
                           const OpenProgress& progress = {});

  std::vector<v1::SceneInfo> list_scenes();

  // Checks that the response's AOVs have the tile's size.
  TileImage render_tile(const v1::RenderTileRequest& request);
  v1::RenderTileResponse render_tile_raw(const v1::RenderTileRequest& request);

  // Explicit receivers; normals need not be unit.
  GatherOutput gather(const std::string& scene_id, const std::vector<Imath::V3f>& positions,
                      const std::vector<Imath::V3f>& normals,
                      const v1::GatherOptions& options = {});
  // The request as given (no client-side checks; tests send malformed ones).
  v1::GatherResponse gather_raw(const v1::GatherRequest& request);

 private:
  // Runs `call` with a fresh ClientContext per attempt, all attempts
  // within one deadline; throws RpcError on failure.
  template <class Call>
  void call_with_retries(const char* rpc, std::chrono::milliseconds deadline, Call&& call);

  std::string address_;
  ClientOptions options_;
  std::unique_ptr<v1::Pbgi::Stub> stub_;
};

// The scene path to send to a daemon on this machine: an existing local file
// becomes its absolute path; anything else is sent as given (the daemon
// looks relative paths up below its scene roots).
std::string scene_request_path(const std::string& scene_argument);

// Adds "unix:" to a bare filesystem path ("/tmp/pbgid.sock", "./cache/pbgid.sock").
std::string normalize_address(const std::string& address);

}  // namespace pbgi::client
