#include "server/service/pbgi_service.h"

#include "server/service/parallel_gather.h"
#include "server/service/receiver_codec.h"
#include "server/service/status_mapping.h"
#include "storage/format/errors.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <chrono>
#include <mutex>

namespace pbgi::service {
namespace {

using Clock = std::chrono::steady_clock;

bool past_deadline(const grpc::ServerContext& context) {
  return std::chrono::system_clock::now() >= context.deadline();
}

// Cancelled work reports DEADLINE_EXCEEDED when the deadline is why.
grpc::Status cancelled_status(const grpc::ServerContext& context, const std::string& what,
                              const Cancelled& e) {
  return grpc::Status(past_deadline(context) ? grpc::StatusCode::DEADLINE_EXCEEDED
                                             : grpc::StatusCode::CANCELLED,
                      what + ": " + e.what());
}

std::string describe(const v1::Tile& t) {
  return fmt::format("tile [{},{})x[{},{})", t.x0(), t.x1(), t.y0(), t.y1());
}

void set_stats(const GatherCounters& counters, double seconds, v1::GatherStats* stats) {
  stats->set_receivers(counters.receivers);
  stats->set_nodes_visited(counters.nodes_visited);
  stats->set_nodes_rasterized(counters.nodes_rasterized);
  stats->set_surfels_raycast(counters.surfels_raycast);
  stats->set_seconds(seconds);
}

// A packed AOV after checking that the renderer produced the expected size.
std::string pack_aov(const std::vector<float>& values, size_t expected, const char* name) {
  if (values.size() != expected) {
    throw Error(fmt::format("renderer returned {} floats for AOV {}, expected {}", values.size(),
                            name, expected));
  }
  return pack_floats(values.data(), values.size());
}

}  // namespace

PbgiService::PbgiService(ServiceOptions options, SceneRoots roots,
                         std::shared_ptr<SceneRegistry> registry)
    : options_(std::move(options)), roots_(std::move(roots)), registry_(std::move(registry)) {}

std::shared_ptr<SceneSession> PbgiService::find_session(const std::string& scene_id) const {
  if (scene_id.empty()) throw InvalidArgument("scene_id is empty");
  std::shared_ptr<SceneSession> session = registry_->find(scene_id);
  if (!session) {
    throw NotFound(fmt::format("scene_id '{}' is not open on this daemon (call OpenScene first)",
                               scene_id));
  }
  return session;
}

std::shared_ptr<SceneSession> PbgiService::open(const std::string& scene_path,
                                                const StageProgress& progress) {
  const std::filesystem::path path = roots_.resolve(scene_path);
  return registry_->open(path, options_.defaults.open, progress);
}

grpc::Status PbgiService::OpenScene(grpc::ServerContext* context,
                                    const v1::OpenSceneRequest* request,
                                    grpc::ServerWriter<v1::OpenSceneEvent>* writer) {
  const std::string what = fmt::format("OpenScene '{}'", request->scene_path());
  return guarded(what, [&]() -> grpc::Status {
    try {
      // 1. Where the scene is, and whether it may be served at all.
      const std::filesystem::path path = roots_.resolve(request->scene_path());
      const OpenOptions options = decode_open_options(request->build(), options_.defaults.open);

      // 2. Open (or join an open in flight), relaying progress. Reports are
      //    thinned to stage changes and steps of 1%; a failed Write means
      //    the client left, which IsCancelled() then reports.
      std::mutex write_mutex;
      std::string last_stage;
      float last_fraction = -1.f;
      auto progress = [&](const std::string& stage, float fraction) {
        std::lock_guard lock(write_mutex);
        if (stage == last_stage && fraction < last_fraction + 0.01f && fraction < 1.f) return;
        last_stage = stage;
        last_fraction = fraction;
        v1::OpenSceneEvent event;
        event.mutable_progress()->set_stage(stage);
        event.mutable_progress()->set_fraction(fraction);
        writer->Write(event);
      };
      auto cancelled = [context] { return context->IsCancelled(); };
      std::shared_ptr<SceneSession> session = registry_->open(path, options, progress, cancelled);

      // 3. The scene's summary ends the stream.
      v1::OpenSceneEvent ready;
      *ready.mutable_ready() = encode_scene_info(*session);
      std::lock_guard lock(write_mutex);
      if (!writer->Write(ready)) {
        return grpc::Status(grpc::StatusCode::CANCELLED, what + ": client went away");
      }
      spdlog::info("opened scene '{}' as {} ({} surfels, {} pages{})", session->info.scene_path,
                   session->info.scene_id, session->info.tree.surfel_count,
                   session->info.tree.page_count,
                   session->info.reused_cache ? ", cached" : "");
      return grpc::Status::OK;
    } catch (const Cancelled& e) {
      return cancelled_status(*context, what, e);
    }
  });
}

grpc::Status PbgiService::ListScenes(grpc::ServerContext*, const v1::ListScenesRequest*,
                                     v1::ListScenesResponse* response) {
  return guarded("ListScenes", [&] {
    for (const auto& session : registry_->list()) {
      *response->add_scenes() = encode_scene_info(*session);
    }
    return grpc::Status::OK;
  });
}

grpc::Status PbgiService::Gather(grpc::ServerContext* context, const v1::GatherRequest* request,
                                 v1::GatherResponse* response) {
  const std::string what = fmt::format("Gather scene '{}'", request->scene_id());
  return guarded(what, [&]() -> grpc::Status {
    try {
      // 1. Check the request's shape before touching any scene.
      const std::vector<Receiver> receivers = decode_receivers(
          request->positions(), request->normals(), options_.limits.max_receivers);
      const GatherOptions options =
          decode_gather_options(request->options(), options_.defaults.render.gather);
      const std::shared_ptr<SceneSession> session = find_session(request->scene_id());

      // 2. Gather over all cores.
      auto cancelled = [context] { return context->IsCancelled() || past_deadline(*context); };
      GatherBatch batch = gather_receivers(*session->tree, receivers, options, cancelled);

      // 3. Packed results.
      std::vector<float> irradiance(3 * receivers.size()), ao(receivers.size());
      for (size_t i = 0; i < receivers.size(); ++i) {
        const GatherResult& r = batch.results[i];
        irradiance[3 * i + 0] = r.irradiance.x;
        irradiance[3 * i + 1] = r.irradiance.y;
        irradiance[3 * i + 2] = r.irradiance.z;
        ao[i] = r.ao;
      }
      response->set_irradiance(pack_floats(irradiance.data(), irradiance.size()));
      response->set_ao(pack_floats(ao.data(), ao.size()));
      set_stats(batch.counters, batch.seconds, response->mutable_stats());
      return grpc::Status::OK;
    } catch (const Cancelled& e) {
      return cancelled_status(*context, what, e);
    }
  });
}

grpc::Status PbgiService::RenderTile(grpc::ServerContext* context,
                                     const v1::RenderTileRequest* request,
                                     v1::RenderTileResponse* response) {
  const std::string what =
      fmt::format("RenderTile scene '{}' camera '{}' {} of {}x{}", request->scene_id(),
                  request->camera(), describe(request->tile()), request->image_width(),
                  request->image_height());
  return guarded(what, [&]() -> grpc::Status {
    try {
      // 1. Scene and camera.
      const std::shared_ptr<SceneSession> session = find_session(request->scene_id());
      if (request->camera().empty()) throw InvalidArgument("RenderTileRequest.camera is empty");
      const auto camera = session->scene->cameras.find(request->camera());
      if (camera == session->scene->cameras.end()) {
        std::string known;
        for (const auto& [path, cam] : session->scene->cameras) known += (known.empty() ? "" : ", ") + path;
        throw NotFound(fmt::format("camera '{}' not found in scene '{}' (cameras: {})",
                                   request->camera(), session->info.scene_path,
                                   known.empty() ? "none" : known));
      }

      // 2. Image and tile.
      const uint32_t width = request->image_width(), height = request->image_height();
      const uint32_t max_side = options_.limits.max_image_side;
      if (width == 0 || height == 0 || width > max_side || height > max_side) {
        throw InvalidArgument(fmt::format(
            "RenderTileRequest image size {}x{} must be between 1 and {} on each side", width,
            height, max_side));
      }
      const v1::Tile& tile = request->tile();
      if (tile.x0() >= tile.x1() || tile.y0() >= tile.y1()) {
        throw InvalidArgument(fmt::format("RenderTileRequest.tile: {} is empty", describe(tile)));
      }
      if (tile.x1() > width || tile.y1() > height) {
        return grpc::Status(grpc::StatusCode::OUT_OF_RANGE,
                            what + ": the tile is outside the image");
      }
      const TileRect rect{tile.x0(), tile.y0(), tile.x1(), tile.y1()};
      const uint64_t pixels = uint64_t(rect.width()) * rect.height();
      if (pixels > options_.limits.max_tile_pixels) {
        throw InvalidArgument(fmt::format("RenderTileRequest.tile: {} has {} pixels, more than "
                                          "the limit of {} per request",
                                          describe(tile), pixels,
                                          options_.limits.max_tile_pixels));
      }
      const RenderOptions options =
          decode_render_options(request->options(), options_.defaults.render);

      // 3. Render, stopping early if the client leaves or the deadline passes.
      const auto start = Clock::now();
      GatherCounters counters;
      auto cancelled = [context] { return context->IsCancelled() || past_deadline(*context); };
      const TileAovs aovs = render_tile(*session->rays, *session->tree, camera->second, width,
                                        height, rect, options, &counters, cancelled);
      const double seconds = std::chrono::duration<double>(Clock::now() - start).count();

      // 4. Packed AOVs.
      *response->mutable_tile() = tile;
      response->set_beauty(pack_aov(aovs.beauty, 3 * pixels, "beauty"));
      response->set_direct(pack_aov(aovs.direct, 3 * pixels, "direct"));
      response->set_indirect(pack_aov(aovs.indirect, 3 * pixels, "indirect"));
      response->set_albedo(pack_aov(aovs.albedo, 3 * pixels, "albedo"));
      response->set_ao(pack_aov(aovs.ao, pixels, "ao"));
      set_stats(counters, seconds, response->mutable_stats());
      return grpc::Status::OK;
    } catch (const Cancelled& e) {
      return cancelled_status(*context, what, e);
    }
  });
}

}  // namespace pbgi::service
