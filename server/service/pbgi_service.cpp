#include "server/service/pbgi_service.h"

#include "common/errors.h"
#include "server/scene/auto_camera.h"
#include "server/scene/render_origin.h"
#include "server/service/interpolated_gather.h"
#include "server/service/parallel_gather.h"
#include "server/service/process_memory.h"
#include "server/service/receiver_codec.h"
#include "server/service/status_mapping.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <mutex>
#include <thread>

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

// `what`: the request, for the warning about non-finite gathers.
void set_stats(const GatherCounters& counters, double seconds, v1::GatherStats* stats, const std::string& what) {
  if (counters.non_finite > 0) {
    spdlog::warn(
        "{}: {} of {} gathers gave a NaN or infinite result, counted as seeing nothing (a defect: "
        "please report it with the scene)",
        what, counters.non_finite, counters.receivers);
  }
  stats->set_non_finite_receivers(counters.non_finite);
  stats->set_receivers(counters.receivers);
  stats->set_nodes_visited(counters.nodes_visited);
  stats->set_nodes_rasterized(counters.nodes_rasterized);
  stats->set_surfels_raycast(counters.surfels_raycast);
  stats->set_seconds(seconds);
  stats->set_glossy_receivers(counters.glossy_receivers);
  stats->set_glossy_nodes_visited(counters.glossy_nodes_visited);
}

// A packed AOV after checking that the renderer produced the expected size.
std::string pack_aov(const std::vector<float>& values, size_t expected, const char* name) {
  if (values.size() != expected) {
    throw Error(fmt::format("renderer returned {} floats for AOV {}, expected {}", values.size(),
                            name, expected));
  }
  return pack_floats(values.data(), values.size());
}

// One packed float32 triple per gather result, `field` of each (a colour
// or a vector).
template <class Triple>
std::string pack_triples(const std::vector<GatherResult>& results, Triple GatherResult::*field) {
  std::vector<float> out(3 * results.size());
  for (size_t i = 0; i < results.size(); ++i) {
    const Triple& t = results[i].*field;
    out[3 * i + 0] = t[0];
    out[3 * i + 1] = t[1];
    out[3 * i + 2] = t[2];
  }
  return pack_floats(out.data(), out.size());
}

uint32_t resolve_max_in_flight(uint32_t configured) {
  if (configured > 0) return configured;
  return 2 * std::max(1u, std::thread::hardware_concurrency());
}

// Progress of an open as events with an estimate of the time left in the
// current stage (from its rate so far), thinned to stage changes and steps
// of 1% so that a fast stage does not flood the stream.
class OpenProgressRelay {
 public:
  explicit OpenProgressRelay(grpc::ServerWriter<v1::OpenSceneEvent>* writer)
      : writer_(writer), start_(Clock::now()), stage_start_(start_) {}

  void report(const std::string& stage, float fraction) {
    std::lock_guard lock(mutex_);
    const auto now = Clock::now();
    if (stage != stage_) {
      stage_ = stage;
      stage_start_ = now;
      last_fraction_ = -1.f;
    } else if (fraction < last_fraction_ + 0.01f && fraction < 1.f) {
      return;
    }
    last_fraction_ = fraction;
    const double in_stage = std::chrono::duration<double>(now - stage_start_).count();
    double eta = -1.0;
    if (fraction >= 1.f) {
      eta = 0.0;
    } else if (fraction >= 0.02f && in_stage > 0.05) {
      eta = in_stage * (1.0 - fraction) / fraction;
    }
    v1::OpenSceneEvent event;
    v1::OpenSceneEvent::Progress* p = event.mutable_progress();
    p->set_stage(stage);
    p->set_fraction(fraction);
    p->set_eta_seconds(eta);
    p->set_elapsed_seconds(std::chrono::duration<double>(now - start_).count());
    writer_->Write(event);  // a failed Write: the client left (IsCancelled says so)
  }

  bool finish(const v1::OpenSceneEvent& ready) {
    std::lock_guard lock(mutex_);
    return writer_->Write(ready);
  }

 private:
  grpc::ServerWriter<v1::OpenSceneEvent>* writer_;
  std::mutex mutex_;
  const Clock::time_point start_;
  Clock::time_point stage_start_;
  std::string stage_;
  float last_fraction_ = -1.f;
};

}  // namespace

// The checked, call-wide parts of a RenderTile(s) request.
struct PbgiService::TileJob {
  std::shared_ptr<SceneSession> session;
  Camera camera;  // a copy: "auto" is made per request
  uint32_t width = 0, height = 0;
  RenderOptions options;
};

PbgiService::PbgiService(ServiceOptions options, SceneRoots roots,
                         std::shared_ptr<SceneRegistry> registry, ServiceRuntime runtime)
    : options_(std::move(options)),
      roots_(std::move(roots)),
      registry_(std::move(registry)),
      runtime_(std::move(runtime)),
      started_(Clock::now()),
      gate_(resolve_max_in_flight(options_.limits.max_in_flight), options_.limits.max_queued) {}

template <class Handler>
grpc::Status PbgiService::serve(grpc::ServerContext* context, const char* rpc,
                                const std::string& what, Handler&& handler) {
  const auto start = Clock::now();
  grpc::Status status = runtime_.auth.check(*context);
  if (!status.ok()) {
    spdlog::warn("{} from {} refused: {}", rpc, context->peer(), status.error_message());
  } else {
    status = guarded(what, [&]() -> grpc::Status {
      try {
        return handler();
      } catch (const Overloaded& e) {
        // The hint travels as trailing metadata so that clients can back
        // off by it without parsing the message.
        context->AddTrailingMetadata("retry-after-ms", std::to_string(e.retry_after_ms));
        spdlog::debug("{}: {}", what, e.what());
        return grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED, what + ": " + e.what());
      } catch (const Cancelled& e) {
        return cancelled_status(*context, what, e);
      }
    });
  }
  metrics_.record(rpc, status.error_code(),
                  std::chrono::duration<double>(Clock::now() - start).count());
  return status;
}

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
  return registry_->open(path, options_.defaults.open, StageSelection{}, progress);
}

grpc::Status PbgiService::OpenScene(grpc::ServerContext* context,
                                    const v1::OpenSceneRequest* request,
                                    grpc::ServerWriter<v1::OpenSceneEvent>* writer) {
  const std::string what = fmt::format("OpenScene '{}'", request->scene_path());
  return serve(context, "OpenScene", what, [&]() -> grpc::Status {
    // 1. Where the scene is, and whether it may be served at all.
    const std::filesystem::path path = roots_.resolve(request->scene_path());
    const OpenOptions options = decode_open_options(request->build(), options_.defaults.open);
    const StageSelection selection = decode_stage_selection(*request);
    // A build asking for more surfels than the daemon allows is refused
    // before the scene is read (a spacing is checked once it is).
    BuildGuard::check_target(options.surfels, options_.limits.max_surfels);

    // 2. Open (or join an open in flight), relaying progress. The build
    //    stops once neither this client nor any other waits for it.
    OpenProgressRelay relay(writer);
    auto cancelled = [context] { return context->IsCancelled() || past_deadline(*context); };
    std::shared_ptr<SceneSession> session = registry_->open(
        path, options, selection,
        [&](const std::string& stage, float fraction) { relay.report(stage, fraction); },
        cancelled);

    // 3. The scene's summary ends the stream.
    v1::OpenSceneEvent ready;
    *ready.mutable_ready() = encode_scene_info(*session);
    if (!relay.finish(ready)) {
      return grpc::Status(grpc::StatusCode::CANCELLED, what + ": client went away");
    }
    spdlog::info("opened scene '{}' as {} ({} surfels, {} pages{})", session->info.scene_path,
                 session->info.scene_id, session->info.tree.surfel_count,
                 session->info.tree.page_count, session->info.reused_cache ? ", cached" : "");
    return grpc::Status::OK;
  });
}

grpc::Status PbgiService::ListScenes(grpc::ServerContext* context, const v1::ListScenesRequest*,
                                     v1::ListScenesResponse* response) {
  return serve(context, "ListScenes", "ListScenes", [&] {
    for (const auto& session : registry_->list()) {
      *response->add_scenes() = encode_scene_info(*session);
    }
    return grpc::Status::OK;
  });
}

grpc::Status PbgiService::UnloadScene(grpc::ServerContext* context,
                                      const v1::UnloadSceneRequest* request,
                                      v1::UnloadSceneResponse*) {
  const std::string what = fmt::format("UnloadScene '{}'", request->scene_id());
  return serve(context, "UnloadScene", what, [&] {
    if (request->scene_id().empty()) throw InvalidArgument("UnloadSceneRequest.scene_id is empty");
    if (!registry_->unload(request->scene_id())) {
      throw NotFound(fmt::format("scene_id '{}' is not open on this daemon", request->scene_id()));
    }
    spdlog::info("unloaded scene {}", request->scene_id());
    return grpc::Status::OK;
  });
}

v1::GetStatusResponse PbgiService::status() const {
  v1::GetStatusResponse out;
  out.set_version(runtime_.version);
  out.set_uptime_seconds(std::chrono::duration<double>(Clock::now() - started_).count());
  const auto now = Clock::now();
  for (const SceneUsage& u : registry_->usage()) {
    v1::SceneStatus* s = out.add_scenes();
    *s->mutable_info() = encode_scene_info(*u.session);
    s->set_idle_seconds(std::chrono::duration<double>(now - u.last_used).count());
    s->set_requests(u.requests);
    s->set_memory_bytes(u.memory_bytes);
  }
  if (runtime_.cache) {
    const storage::CacheCounters c = runtime_.cache->counters();
    v1::CacheStatus* cache = out.mutable_cache();
    cache->set_hits(c.hits);
    cache->set_misses(c.misses);
    cache->set_evictions(c.evictions);
    cache->set_bytes_read(c.bytes_read);
    cache->set_bytes_held(c.bytes_held);
    cache->set_bytes_pinned(c.bytes_pinned);
    cache->set_bytes_pinned_peak(c.bytes_pinned_peak);
    cache->set_budget_bytes(runtime_.cache->budget());
  }
  out.set_rss_bytes(resident_memory_bytes());
  const AdmissionCounters a = gate_.counters();
  v1::RequestStatus* r = out.mutable_requests();
  r->set_in_flight(a.in_flight);
  r->set_queued(a.queued);
  r->set_max_in_flight(a.max_in_flight);
  r->set_max_queued(a.max_queued);
  r->set_completed(a.completed);
  r->set_rejected(a.rejected);
  for (const OpeningScene& o : registry_->opening()) {
    v1::OpenStatus* s = out.add_opening();
    s->set_scene_path(o.scene_path);
    s->set_stage(o.stage);
    s->set_fraction(o.fraction);
  }
  out.set_scene_memory_budget_bytes(registry_->memory_budget());
  if (runtime_.memory) {
    const MemoryUsage u = runtime_.memory->usage();
    v1::MemoryStatus* m = out.mutable_memory();
    m->set_budget_bytes(u.budget.total);
    m->set_request_reserve_bytes(u.budget.request_reserve);
    m->set_page_cache_floor_bytes(u.budget.cache_floor);
    m->set_scenes_bytes(u.charged[size_t(ChargeKind::kScene)]);
    m->set_reading_bytes(u.charged[size_t(ChargeKind::kRead)]);
    m->set_builds_bytes(u.charged[size_t(ChargeKind::kBuild)]);
    m->set_refusals(u.refusals);
  }
  return out;
}

grpc::Status PbgiService::GetStatus(grpc::ServerContext* context, const v1::GetStatusRequest*,
                                    v1::GetStatusResponse* response) {
  return serve(context, "GetStatus", "GetStatus", [&] {
    *response = status();
    return grpc::Status::OK;
  });
}

grpc::Status PbgiService::Gather(grpc::ServerContext* context, const v1::GatherRequest* request,
                                 v1::GatherResponse* response) {
  const std::string what = fmt::format("Gather scene '{}'", request->scene_id());
  return serve(context, "Gather", what, [&]() -> grpc::Status {
    // 1. Check the request's shape before touching any scene.
    std::vector<Receiver> receivers = decode_receivers(
        request->positions(), request->normals(), options_.limits.max_receivers);
    if (receivers.empty()) {
      throw InvalidArgument("GatherRequest.positions is empty: no receivers to gather");
    }
    decode_glossy_receivers(request->view_directions(), request->roughness(),
                            request->specular_color(), receivers);
    const GatherOptions options =
        decode_gather_options(request->options(), options_.defaults.render.gather);
    const InterpolationOptions interpolation =
        decode_interpolation_options(request->options(), options_.defaults.render.interpolation);
    const std::shared_ptr<SceneSession> session = find_session(request->scene_id());
    // Receivers come in world coordinates; the session renders in its
    // scene-local frame (server/scene/render_origin.h).
    if (session->scene) {
      for (Receiver& r : receivers) {
        r.position = to_local(*session->scene, V3d(r.position.x, r.position.y, r.position.z));
      }
    }

    // 2. A worker slot, then the gather over all cores: every receiver, or
    //    a subset and the rest interpolated (interpolated_gather.h); both
    //    give up when the client leaves or the deadline passes.
    auto cancelled = [context] { return context->IsCancelled() || past_deadline(*context); };
    const AdmissionGate::Ticket slot = gate_.enter(context->deadline(), cancelled);
    const GatherBatch batch =
        interpolation.mode == InterpolationMode::kOff
            ? gather_receivers(*session->tree, receivers, options, cancelled, session->fog, session->rays.get())
            : gather_interpolated(*session->tree, receivers, options, interpolation.tolerance, cancelled, session->fog,
                                  session->rays.get());

    // 3. Packed results.
    std::vector<float> ao(receivers.size());
    for (size_t i = 0; i < receivers.size(); ++i) ao[i] = batch.results[i].ao;
    response->set_irradiance(pack_triples(batch.results, &GatherResult::irradiance));
    response->set_ao(pack_floats(ao.data(), ao.size()));
    // Glossy radiance towards each receiver's view (0 for diffuse ones).
    if (!request->specular_color().empty()) response->set_glossy(pack_triples(batch.results, &GatherResult::glossy));
    if (options.bent_normal) response->set_bent_normals(pack_triples(batch.results, &GatherResult::bent_normal));
    set_stats(batch.counters, batch.seconds, response->mutable_stats(), what);
    response->mutable_stats()->set_requested_receivers(receivers.size());
    return grpc::Status::OK;
  });
}

PbgiService::TileJob PbgiService::prepare_tiles(const std::string& scene_id,
                                                const std::string& camera, uint32_t width,
                                                uint32_t height,
                                                const v1::GatherOptions& options) const {
  TileJob job;
  // 1. Scene and camera.
  job.session = find_session(scene_id);
  if (camera.empty()) throw InvalidArgument("camera is empty");

  // 2. Image size and options.
  const uint32_t max_side = options_.limits.max_image_side;
  if (width == 0 || height == 0 || width > max_side || height > max_side) {
    throw InvalidArgument(fmt::format("image size {}x{} must be between 1 and {} on each side",
                                      width, height, max_side));
  }
  // A camera prim, or "auto": framed for this image's aspect (auto_camera.h).
  job.camera = resolve_camera(*job.session->scene, camera, float(width) / float(height));
  job.width = width;
  job.height = height;
  job.options = decode_render_options(options, options_.defaults.render);
  return job;
}

TileRect PbgiService::check_tile(const TileJob& job, const v1::Tile& tile) const {
  if (tile.x0() >= tile.x1() || tile.y0() >= tile.y1()) {
    throw InvalidArgument(fmt::format("{} is empty", describe(tile)));
  }
  if (tile.x1() > job.width || tile.y1() > job.height) {
    throw OutOfRange(fmt::format("{} is outside the {}x{} image", describe(tile), job.width,
                                 job.height));
  }
  const TileRect rect{tile.x0(), tile.y0(), tile.x1(), tile.y1()};
  const uint64_t pixels = uint64_t(rect.width()) * rect.height();
  if (pixels > options_.limits.max_tile_pixels) {
    throw InvalidArgument(fmt::format("{} has {} pixels, more than the limit of {} per tile",
                                      describe(tile), pixels, options_.limits.max_tile_pixels));
  }
  return rect;
}

void PbgiService::render_one(grpc::ServerContext* context, const TileJob& job,
                             const v1::Tile& tile, v1::RenderTileResponse* response) {
  const TileRect rect = check_tile(job, tile);
  const uint64_t pixels = uint64_t(rect.width()) * rect.height();

  // A worker slot, then the render; both stop early if the client leaves
  // or the deadline passes (the renderer polls between rows and batches).
  auto cancelled = [context] { return context->IsCancelled() || past_deadline(*context); };
  const AdmissionGate::Ticket slot = gate_.enter(context->deadline(), cancelled);
  const auto start = Clock::now();
  GatherCounters counters;
  const TileAovs aovs = render_tile(*job.session->rays, *job.session->tree, job.camera,
                                    job.width, job.height, rect, job.options, &counters,
                                    cancelled, job.session->fog);
  const double seconds = std::chrono::duration<double>(Clock::now() - start).count();

  *response->mutable_tile() = tile;
  response->set_beauty(pack_aov(aovs.beauty, 3 * pixels, "beauty"));
  response->set_direct(pack_aov(aovs.direct, 3 * pixels, "direct"));
  response->set_indirect(pack_aov(aovs.indirect, 3 * pixels, "indirect"));
  response->set_albedo(pack_aov(aovs.albedo, 3 * pixels, "albedo"));
  response->set_ao(pack_aov(aovs.ao, pixels, "ao"));
  set_stats(counters, seconds, response->mutable_stats(),
            fmt::format("RenderTile scene '{}' {}", job.session->info.scene_id, describe(tile)));
  response->mutable_stats()->set_camera_samples(aovs.camera_samples);
  response->mutable_stats()->set_pixels(pixels);
}

grpc::Status PbgiService::RenderTile(grpc::ServerContext* context,
                                     const v1::RenderTileRequest* request,
                                     v1::RenderTileResponse* response) {
  const std::string what =
      fmt::format("RenderTile scene '{}' camera '{}' {} of {}x{}", request->scene_id(),
                  request->camera(), describe(request->tile()), request->image_width(),
                  request->image_height());
  return serve(context, "RenderTile", what, [&] {
    const TileJob job = prepare_tiles(request->scene_id(), request->camera(),
                                      request->image_width(), request->image_height(),
                                      request->options());
    render_one(context, job, request->tile(), response);
    return grpc::Status::OK;
  });
}

grpc::Status PbgiService::RenderTiles(grpc::ServerContext* context,
                                      const v1::RenderTilesRequest* request,
                                      grpc::ServerWriter<v1::RenderTileResponse>* writer) {
  const std::string what =
      fmt::format("RenderTiles scene '{}' camera '{}' ({} tiles of {}x{})", request->scene_id(),
                  request->camera(), request->tiles_size(), request->image_width(),
                  request->image_height());
  return serve(context, "RenderTiles", what, [&]() -> grpc::Status {
    // 1. The whole request is checked before any tile is rendered, so that a
    //    bad tile costs no work.
    if (request->tiles_size() == 0) throw InvalidArgument("RenderTilesRequest.tiles is empty");
    if (uint32_t(request->tiles_size()) > options_.limits.max_tiles_per_call) {
      throw InvalidArgument(fmt::format("RenderTilesRequest.tiles has {} tiles, more than the "
                                        "limit of {} per call",
                                        request->tiles_size(),
                                        options_.limits.max_tiles_per_call));
    }
    const TileJob job = prepare_tiles(request->scene_id(), request->camera(),
                                      request->image_width(), request->image_height(),
                                      request->options());
    for (int i = 0; i < request->tiles_size(); ++i) {
      try {
        check_tile(job, request->tiles(i));
      } catch (const InvalidArgument& e) {
        throw InvalidArgument(fmt::format("RenderTilesRequest.tiles[{}]: {}", i, e.what()));
      } catch (const OutOfRange& e) {
        throw OutOfRange(fmt::format("RenderTilesRequest.tiles[{}]: {}", i, e.what()));
      }
    }

    // 2. Tile by tile, each taking its own worker slot (a long stream does
    //    not starve other clients), each sent as soon as it is done.
    for (int i = 0; i < request->tiles_size(); ++i) {
      // Between tiles no slot is held: a client that left must not get
      // the next one started.
      if (context->IsCancelled()) {
        throw Cancelled(fmt::format("client went away after {} tiles", i));
      }
      v1::RenderTileResponse response;
      render_one(context, job, request->tiles(i), &response);
      if (!writer->Write(response)) {
        return grpc::Status(grpc::StatusCode::CANCELLED,
                            fmt::format("{}: client went away after {} tiles", what, i));
      }
    }
    return grpc::Status::OK;
  });
}

}  // namespace pbgi::service
