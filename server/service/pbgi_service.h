// pbgi.v1.Pbgi over the libraries: OpenScene -> SceneRegistry/open_scene,
// Gather -> gather_receivers, RenderTile(s) -> render_tile. Handlers only
// authenticate, check requests, take an admission slot for the expensive
// calls, convert messages and map errors (status_mapping.h); every call is
// counted in metrics() by RPC, status and latency.
//
// How to add an RPC:
//  1. The rpc and its messages in proto/pbgi/v1/pbgi.proto, additive only
//     (docs/protocol.md: new messages, fields, RPCs, enum values).
//  2. A handler here that is thin: its body runs inside serve(), which
//     authenticates, counts the call under its name and maps the core
//     library's errors (common/errors.h) to status codes
//     (status_mapping.h); expensive work also takes an admission slot
//     (admission.h). Request fields are checked before any work and named
//     in InvalidArgument; the work itself belongs to a library below.
//  3. The client library's call (client/lib/pbgi_client.h, with deadline
//     and retries) and, if users need it, a `pbgi` subcommand.
//  4. A row in docs/protocol.md's RPC table; tests in
//     tests/server/service/ (each error code it can return) and through
//     the client (tests/client/lib/).
#pragma once

#include "pbgi/v1/pbgi.grpc.pb.h"
#include "common/options/option_table.h"
#include "server/engine/memory_accountant.h"
#include "server/service/admission.h"
#include "server/service/bearer_auth.h"
#include "server/service/options_codec.h"
#include "server/service/request_metrics.h"
#include "server/service/scene_registry.h"
#include "server/service/scene_roots.h"
#include "storage/cache/page_cache.h"

#include <chrono>
#include <cstdint>
#include <memory>

namespace pbgi::service {

// Per-request limits, so that one request cannot take the daemon down.
struct RequestLimits {
  uint64_t max_receivers = 1u << 20;      // receivers per Gather request
  uint32_t max_image_side = 16384;        // RenderTile image width / height
  uint64_t max_tile_pixels = 512 * 512;   // pixels per RenderTile tile
  uint32_t max_tiles_per_call = 4096;     // tiles per RenderTiles call
  // Surfels one page-set build may produce, whoever asks (OpenScene or
  // --preload); 0 = no limit. An OpenScene whose target_surfels or whose
  // spacing over the scene's area asks for more gets RESOURCE_EXHAUSTED
  // before any work; a camera-adaptive build is stopped once it passes it
  // by 1% (server/engine/build_guard.h). The default admits twice the largest
  // build measured (docs/out-of-core.md: 105 M surfels).
  uint64_t max_surfels = 200'000'000;
  // Expensive calls (Gather, each tile) running at once; 0 = 2 x cores.
  uint32_t max_in_flight = 0;
  // More waiting for a slot; beyond: RESOURCE_EXHAUSTED + retry-after-ms.
  uint32_t max_queued = 64;
};

// RequestLimits' options (common/options/option_table.h): [limits] in the
// config; not part of any request.
inline constexpr auto kRequestLimitsTable = options::table(
    options::field<&RequestLimits::max_receivers>("max_receivers"),
    options::field<&RequestLimits::max_image_side>("max_image_side"),
    options::field<&RequestLimits::max_tile_pixels>("max_tile_pixels"),
    options::field<&RequestLimits::max_tiles_per_call>("max_tiles_per_call"),
    options::field<&RequestLimits::max_in_flight>("max_in_flight"),
    options::field<&RequestLimits::max_queued>("max_queued"),
    options::field<&RequestLimits::max_surfels>("max_surfels"));

struct ServiceOptions {
  RequestDefaults defaults;
  RequestLimits limits;
};

// What the service gets from the daemon besides its options.
struct ServiceRuntime {
  BearerAuth auth{};                                 // default: no token required
  std::shared_ptr<const storage::PageCache> cache;   // for GetStatus (may be null)
  std::shared_ptr<const MemoryAccountant> memory;    // for GetStatus (may be null)
  std::string version;
};

// Thread-safe: gRPC calls the handlers from its thread pool concurrently.
class PbgiService final : public v1::Pbgi::Service {
 public:
  PbgiService(ServiceOptions options, SceneRoots roots, std::shared_ptr<SceneRegistry> registry,
              ServiceRuntime runtime = {});

  grpc::Status OpenScene(grpc::ServerContext* context, const v1::OpenSceneRequest* request,
                         grpc::ServerWriter<v1::OpenSceneEvent>* writer) override;
  grpc::Status ListScenes(grpc::ServerContext* context, const v1::ListScenesRequest* request,
                          v1::ListScenesResponse* response) override;
  grpc::Status Gather(grpc::ServerContext* context, const v1::GatherRequest* request,
                      v1::GatherResponse* response) override;
  grpc::Status RenderTile(grpc::ServerContext* context, const v1::RenderTileRequest* request,
                          v1::RenderTileResponse* response) override;
  grpc::Status RenderTiles(grpc::ServerContext* context, const v1::RenderTilesRequest* request,
                           grpc::ServerWriter<v1::RenderTileResponse>* writer) override;
  grpc::Status UnloadScene(grpc::ServerContext* context, const v1::UnloadSceneRequest* request,
                           v1::UnloadSceneResponse* response) override;
  grpc::Status GetStatus(grpc::ServerContext* context, const v1::GetStatusRequest* request,
                         v1::GetStatusResponse* response) override;

  // Opens a scene as OpenScene does, without a client (the daemon's --preload).
  std::shared_ptr<SceneSession> open(const std::string& scene_path,
                                     const StageProgress& progress = {});

  // What GetStatus answers (also the daemon's metrics endpoint).
  v1::GetStatusResponse status() const;
  RequestMetricsSnapshot metrics() const { return metrics_.snapshot(); }

  const SceneRegistry& registry() const { return *registry_; }
  const RequestLimits& limits() const { return options_.limits; }

 private:
  struct TileJob;
  std::shared_ptr<SceneSession> find_session(const std::string& scene_id) const;
  // Authentication, exception mapping and metrics around one handler.
  template <class Handler>
  grpc::Status serve(grpc::ServerContext* context, const char* rpc, const std::string& what,
                     Handler&& handler);
  // Checks the parts of a RenderTile(s) request common to all its tiles.
  TileJob prepare_tiles(const std::string& scene_id, const std::string& camera, uint32_t width,
                        uint32_t height, const v1::GatherOptions& options) const;
  TileRect check_tile(const TileJob& job, const v1::Tile& tile) const;
  void render_one(grpc::ServerContext* context, const TileJob& job, const v1::Tile& tile,
                  v1::RenderTileResponse* response);

  const ServiceOptions options_;
  const SceneRoots roots_;
  const std::shared_ptr<SceneRegistry> registry_;
  const ServiceRuntime runtime_;
  const std::chrono::steady_clock::time_point started_;
  AdmissionGate gate_;
  RequestMetrics metrics_;
};

}  // namespace pbgi::service
