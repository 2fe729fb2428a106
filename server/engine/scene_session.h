// An open scene in the daemon: its geometry for ray queries and its tree of
// surfels on disk. open_scene() runs the whole pipeline once per scene and
// build options: ingest -> surfels -> tree pages (reused if already built).
#pragma once

#include "server/engine/build_guard.h"
#include "server/engine/memory_accountant.h"
#include "server/engine/open_options.h"
#include "server/gather/surfel_bounce.h"
#include "server/ingest/chunk_store.h"
#include "server/ingest/usd_ingest.h"
#include "server/scene/ray_scene.h"
#include "server/scene/volume_points.h"
#include "server/surfels/surfel_options.h"
#include "server/volumes/fog_options.h"
#include "storage/cache/page_cache.h"
#include "storage/pages/page_set.h"
#include "storage/pages/staging_quota.h"
#include "storage/tree/build_options.h"

#include <filesystem>
#include <functional>
#include <memory>
#include <string>

namespace pbgi {

struct SceneSessionInfo {
  std::string scene_id;          // the page set's build key
  std::string scene_path;
  uint64_t triangle_count = 0;
  storage::PageSetStats tree;
  bool reused_cache = false;     // the page set was built before
  bool reused_ingest = false;    // the scene came from the chunk store
  double open_seconds = 0;
};

struct SceneSession {
  // The session's share of the daemon's memory budget: its geometry and
  // ray-tracing structure, measured (ChargeKind::kScene; taken over from
  // the read's charge), and a build's working memory while it runs
  // (kBuild); released when the session goes.
  // Declared first: released after what it counts is freed.
  MemoryCharge memory;
  std::unique_ptr<Scene> scene;
  std::unique_ptr<RayScene> rays;
  // Fog volume points for every Gatherer (Gatherer::set_volume_points);
  // null without fog. See scene_fog.h.
  std::shared_ptr<const VolumePoints> fog;
  std::unique_ptr<storage::PageSetReader> tree;
  SceneSessionInfo info;
};

struct EngineContext {
  std::filesystem::path cache_dir;              // page sets live here
  std::shared_ptr<storage::PageCache> cache;    // shared page cache
  std::string python;                           // interpreter for the USD reader
  // Ingested scenes (refined meshes Draco-compressed, server/ingest/
  // chunk_store.h) so that reopening an unchanged scene skips the USD
  // traversal and refinement; null = always ingest.
  std::shared_ptr<const ChunkStore> ingested;
  // Bounds on every build, whoever asks (the daemon's limits.max_surfels
  // and staging_quota): a build that would pass one stops with
  // ResourceExhausted naming it and leaves nothing behind. 0 / null: none.
  uint64_t max_surfels = 0;
  std::shared_ptr<storage::StagingQuota> staging_quota;
  // The daemon's memory budget (memory_accountant.h): each session is
  // charged for its geometry and ray structure, each build for its working
  // memory, before they are allocated. Null: nothing is charged.
  std::shared_ptr<MemoryAccountant> memory;
};

using StageProgress = std::function<void(const std::string& stage, float fraction)>;

// Opens `scene_path` (already checked against the scene roots): reads the USD
// scene (or reuses it from ctx.ingested), samples and shades surfels, builds
// or reuses the page set. `composition` carries the stage's variant
// selections and time code; its python and target_edge_length are set here
// (from ctx and the surfel spacing). `cancelled` is polled while reading and
// between build batches (build_guard.h): once true the open stops with
// Cancelled, its reader process and staging directories removed.
// Throws SceneError / IoError / CorruptionError with the file at fault,
// ResourceExhausted past ctx's bounds (the memory budget: naming the scene
// and the bytes it needs; while the scene is read, charged chunk by chunk,
// also the frame and prim it had reached), Cancelled.
std::shared_ptr<SceneSession> open_scene(const std::filesystem::path& scene_path,
                                         const OpenOptions& options, const EngineContext& ctx,
                                         const StageProgress& progress = {},
                                         IngestOptions composition = {},
                                         const CancelledFn& cancelled = {});

// The same pipeline from step 2 on, for a scene already in memory (built in
// code by tests and benchmarks, or read by the caller). scene->content_hash
// keys the page set: give distinct scenes distinct hashes.
std::shared_ptr<SceneSession> open_scene_model(std::unique_ptr<Scene> scene,
                                               const OpenOptions& options,
                                               const EngineContext& ctx,
                                               const StageProgress& progress = {},
                                               const CancelledFn& cancelled = {});

}  // namespace pbgi
