// pbgi.v1.Pbgi over the libraries: OpenScene -> SceneRegistry/open_scene,
// Gather -> gather_receivers, RenderTile -> render_tile. Handlers only
// check requests, convert messages and map errors (status_mapping.h).
#pragma once

#include "pbgi/v1/pbgi.grpc.pb.h"
#include "server/service/options_codec.h"
#include "server/service/scene_registry.h"
#include "server/service/scene_roots.h"

#include <cstdint>
#include <memory>

namespace pbgi::service {

// Per-request limits, so that one request cannot take the daemon down.
struct RequestLimits {
  uint64_t max_receivers = 1u << 20;      // receivers per Gather request
  uint32_t max_image_side = 16384;        // RenderTile image width / height
  uint64_t max_tile_pixels = 512 * 512;   // pixels per RenderTile tile
};

struct ServiceOptions {
  RequestDefaults defaults;
  RequestLimits limits;
};

// Thread-safe: gRPC calls the handlers from its thread pool concurrently.
class PbgiService final : public v1::Pbgi::Service {
 public:
  PbgiService(ServiceOptions options, SceneRoots roots, std::shared_ptr<SceneRegistry> registry);

  grpc::Status OpenScene(grpc::ServerContext* context, const v1::OpenSceneRequest* request,
                         grpc::ServerWriter<v1::OpenSceneEvent>* writer) override;
  grpc::Status ListScenes(grpc::ServerContext* context, const v1::ListScenesRequest* request,
                          v1::ListScenesResponse* response) override;
  grpc::Status Gather(grpc::ServerContext* context, const v1::GatherRequest* request,
                      v1::GatherResponse* response) override;
  grpc::Status RenderTile(grpc::ServerContext* context, const v1::RenderTileRequest* request,
                          v1::RenderTileResponse* response) override;

  // Opens a scene as OpenScene does, without a client (the daemon's --preload).
  std::shared_ptr<SceneSession> open(const std::string& scene_path,
                                     const StageProgress& progress = {});

  const SceneRegistry& registry() const { return *registry_; }

 private:
  std::shared_ptr<SceneSession> find_session(const std::string& scene_id) const;

  const ServiceOptions options_;
  const SceneRoots roots_;
  const std::shared_ptr<SceneRegistry> registry_;
};

}  // namespace pbgi::service
