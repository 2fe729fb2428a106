// C++ client of pbgid: one channel, typed calls with per-call deadlines and
// retries with exponential backoff on UNAVAILABLE (daemon starting or
// restarting) and on RESOURCE_EXHAUSTED that carries the daemon's
// "retry-after-ms" hint (overloaded: it waits at least that long).
// Optionally TLS (server CA, client certificate) and a bearer token sent
// as "authorization: Bearer <token>" on every call. Failures throw
// RpcError (a pbgi::Error) with the server's message.
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
  // Retry RESOURCE_EXHAUSTED answers that carry "retry-after-ms" (the
  // daemon's admission limit), within max_attempts and the deadline.
  bool retry_overloaded = true;
  // TLS: the PEM file of the CA that signed the daemon's certificate; ""
  // = plaintext (unix sockets, loopback). With tls_cert_file/tls_key_file
  // the client presents its own certificate (daemons with tls_client_ca).
  std::string tls_ca_file;
  std::string tls_cert_file, tls_key_file;
  // Name checked against the daemon's certificate instead of the host of
  // the address (e.g. "localhost" when connecting to 127.0.0.1).
  std::string tls_server_name;
  // Bearer token; "" = none.
  std::string token;
};

using OpenProgress = std::function<void(const std::string& stage, float fraction)>;
// The full progress event (with its ETA).
using OpenProgressEvent = std::function<void(const v1::OpenSceneEvent::Progress& progress)>;

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
  // With GatherOptions.bent_normal: one unit vector per receiver; else empty.
  std::vector<Imath::V3f> bent_normals;
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

  // The same with every OpenSceneRequest field (variant selections, time
  // code) and the full progress events.
  v1::SceneInfo open_scene(const v1::OpenSceneRequest& request,
                           const OpenProgressEvent& progress);

  std::vector<v1::SceneInfo> list_scenes();

  // Scenes, cache, memory and request counters of the daemon.
  v1::GetStatusResponse status();

  // Unloads a scene; throws RpcError NOT_FOUND if it is not open.
  void unload_scene(const std::string& scene_id);

  // Many tiles over one call; `on_tile` gets each (checked like
  // render_tile) in request order as it arrives, on the calling thread.
  // Retried only until the first tile arrives. The call deadline applies
  // to the whole stream.
  void render_tiles(const v1::RenderTilesRequest& request,
                    const std::function<void(TileImage&& tile)>& on_tile);

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

// RenderTile(s)Request.camera naming the daemon's auto camera: the scene's
// bounds framed for the image's aspect (docs/protocol.md).
inline constexpr const char* kAutoCamera = "auto";

// The camera to request: `requested` if set, else the scene's only camera,
// else kAutoCamera for a scene without any. Throws InvalidArgument naming
// the cameras when the scene has several and none was requested.
std::string camera_for(const v1::SceneInfo& info, const std::string& requested);

// A RenderTileResponse as a TileImage; throws CorruptionError if an AOV
// does not have the tile's size.
TileImage decode_tile(const v1::RenderTileResponse& response);

// Adds "unix:" to a bare filesystem path ("/tmp/pbgid.sock", "./cache/pbgid.sock").
std::string normalize_address(const std::string& address);

// The channel PbgiClient uses for `target` (already normalized): TLS and
// reconnect backoff from `options` (the token is per call, not here).
// Throws IoError / InvalidArgument for unreadable or inconsistent TLS files.
std::shared_ptr<grpc::Channel> make_channel(const std::string& target, const ClientOptions& options);

}  // namespace pbgi::client
