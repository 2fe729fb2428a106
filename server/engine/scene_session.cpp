#include "server/engine/scene_session.h"

#include "server/scene/air_regions.h"

#include "server/engine/cache_cleanup.h"
#include "server/engine/scene_fog.h"
#include "server/surfels/surfel_samplers.h"

#include "common/errors.h"
#include "server/engine/bounce_pages.h"
#include "server/engine/build_key.h"
#include "server/engine/scene_memory.h"
#include "server/gather/page_views.h"
#include "server/ingest/usd_ingest.h"
#include "server/scene/default_lights.h"
#include "server/scene/render_origin.h"
#include "server/scene/scene_bulk.h"
#include "server/surfels/glossy_shading.h"
#include "server/surfels/surfel_gloss_lookup.h"
#include "server/surfels/surfels.h"
#include "storage/pages/cache_files.h"

#include <spdlog/spdlog.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <system_error>

namespace pbgi {
namespace {

namespace fs = std::filesystem;

// A page set that fails verification is moved aside (kept for inspection)
// and rebuilt: a corrupt page set is never served.
std::unique_ptr<storage::PageSetReader> try_open_existing(const fs::path& dir, const EngineContext& ctx) {
  if (!fs::exists(dir / "manifest.pbgm")) return nullptr;
  try {
    return std::make_unique<storage::PageSetReader>(dir, ctx.cache, gather::attach_view);
  } catch (const Error& e) {
    const auto aside = fs::path(dir.string() + std::string(kCorruptPageSetSuffix) +
                                std::to_string(std::chrono::system_clock::now().time_since_epoch().count()));
    spdlog::warn("page set {} failed verification ({}); moving it to {} and rebuilding", dir.string(), e.what(),
                 aside.string());
    std::error_code ec;
    fs::rename(dir, aside, ec);
    if (ec) throw IoError("cannot move corrupt page set " + dir.string() + " aside: " + ec.message());
    return nullptr;
  }
}

// One line per build with where its time went, so that the throughput of
// a production-size build can be read from the daemon's log.
void log_build(const std::string& key, const SurfelGenerationStats& g, const storage::BuildReport& r,
               const storage::PageSetStats& s) {
  const double n = double(g.surfels);
  const double tree_seconds = r.add_seconds + r.finish_seconds;  // sort runs + merge, tree, pages
  spdlog::info(
      "built page set {}: {} surfels; sample {:.1f} s + shade {:.1f} s ({:.3g} surfels/s), tree {:.1f} s "
      "({:.3g} surfels/s; {} sort runs, {} merges, {:.2f} run bytes/surfel), {} pages, {:.2f} bytes/surfel",
      key, g.surfels, g.sample_seconds, g.shade_seconds, n / std::max(1e-9, g.sample_seconds + g.shade_seconds),
      tree_seconds, n / std::max(1e-9, tree_seconds), r.runs, r.merges, double(r.run_bytes) / std::max(1.0, n),
      s.page_count, double(s.file_bytes) / std::max(1.0, n));
  spdlog::info("page set {}: payloads {}", key, r.codec_reason);
  if (r.glossy.pages > 0) {
    spdlog::info(
        "page set {}: {} glossy surfels, wavelet radiance in {} pages, {} bytes ({} face blocks kept, "
        "{} dropped), lobes lit in {:.1f} s",
        key, r.glossy.glossy_surfels, r.glossy.pages, r.glossy.bytes, r.glossy.kept_blocks, r.glossy.dropped_blocks,
        r.glossy.shade_seconds);
  }
}

// Runs `build`, which publishes the page set `dir`, and opens it. If
// another process (a replica sharing the cache directory) published the
// same content-addressed set first, the build stops and that one is opened.
std::unique_ptr<storage::PageSetReader> build_or_join(const fs::path& dir, const EngineContext& ctx,
                                                      const std::function<void()>& build) {
  try {
    build();
  } catch (const AlreadyExists& e) {
    spdlog::info("page set {} was published by another build meanwhile ({}); using it", dir.string(), e.what());
  }
  return std::make_unique<storage::PageSetReader>(dir, ctx.cache, gather::attach_view);
}

std::shared_ptr<SceneSession> open_read_scene(std::unique_ptr<Scene> scene, const OpenOptions& options,
                                              const EngineContext& ctx, const StageProgress& progress,
                                              const CancelledFn& cancelled, MemoryCharge read);

// Builds the page set of `options` (steps 4-6 of open_scene_model), and
// the sets it builds on that are missing: the set of direct light, then one
// per extra bounce. Each is content-addressed, so what exists is reused.
// `charge_tables` (may be empty) is told the bytes of the page tables the
// builds hold, before each growth (PageSetBuilder::set_memory_hook): the
// table a build writes and those of the sets open meanwhile (a bounce's
// direct and previous sets); it throws to refuse them.
std::unique_ptr<storage::PageSetReader> build_page_sets(const SceneSession& session, const OpenOptions& options,
                                                        const EngineContext& ctx,
                                                        const std::function<void(const std::string&, float)>& report,
                                                        const CancelledFn& cancelled,
                                                        const std::function<void(uint64_t)>& charge_tables) {
  const Scene& scene = *session.scene;
  // The Morton cube spans the bulk: a far outlier must not coarsen the
  // order of everything else (its surfels sort at the cube's edge).
  const Box3f order_bounds = scene_bulk(scene).bounds;
  BuildGuard guard(scene.source_path, ctx.max_surfels, cancelled);
  OpenOptions direct_options = options;
  direct_options.bounce.bounces = 1;
  fs::path dir = ctx.cache_dir / page_set_build_key(scene.content_hash, direct_options);
  std::unique_ptr<storage::PageSetReader> tree = try_open_existing(dir, ctx);
  std::unique_ptr<storage::PageSetReader> direct;
  // The memory hook of the next build: its table's bytes and those of the
  // sets open while it runs.
  auto table_hook = [&]() -> std::function<void(uint64_t)> {
    if (!charge_tables) return {};
    uint64_t open = 0;
    for (const auto* set : {tree.get(), direct.get()}) open += set ? set->manifest().pages.memory_bytes() : 0;
    return [&charge_tables, open](uint64_t building) { charge_tables(open + building); };
  };
  if (!tree) {
    tree = build_or_join(dir, ctx, [&] {
      // 4. Surfels, sampled and shaded batch by batch, streamed into the
      //    page-set build (external sort by Morton code, bounded memory),
      //    within the daemon's bounds and while a client waits for them.
      guard.check_cancelled();
      guard.check_expected(scene, options.surfels);
      storage::PageSetBuilder builder(options.tree, dir.filename().string(), dir, order_bounds);
      builder.set_staging_quota(ctx.staging_quota);
      builder.set_memory_hook(table_hook());
      // Glossy senders' lobes are lit while their pages are written.
      const SceneGlossyShader glossy(*session.rays, options.surfels.light_samples, options.surfels.seed);
      builder.set_glossy_shader(&glossy);
      // 4a. Air regions: the closed parts of the scene's empty space; each
      //     surfel goes to the one its front faces (docs/gather.md, section 11).
      tree::RegionGrid regions;
      if (options.tree.air_region_resolution != 0) {
        report("air regions", 0.f);
        const auto t0 = std::chrono::steady_clock::now();
        regions = build_air_regions(scene, *session.rays, options.tree.air_region_resolution);
        const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        report("air regions", 1.f);
        if (regions.region_count() > 1) {
          spdlog::info("scene {}: {} air regions on a {}x{}x{} grid of {} voxels ({:.2f} s)", scene.source_path,
                       regions.region_count(), regions.dims().x, regions.dims().y, regions.dims().z, regions.voxel(),
                       seconds);
        } else {
          regions = {};
        }
      }
      std::vector<Surfel> located;
      const SurfelGenerationStats generated = generate_surfels(
          scene, *session.rays, options.surfels,
          [&](std::span<const Surfel> batch) {
            guard.count(batch.size());
            if (regions.empty()) {
              builder.add(batch);
              return;
            }
            located.assign(batch.begin(), batch.end());
            tbb::parallel_for(size_t(0), located.size(), [&](size_t i) {
              Surfel& s = located[i];
              s.region = locate_region(regions, *session.rays, s.position, s.normal, true);
            });
            builder.add(located);
          },
          [&](const char* s, float f) { report(s, f); });
      if (!regions.empty()) builder.set_regions(std::move(regions));
      // 5. Tree pages, published atomically into the cache directory.
      const storage::Manifest built = builder.finish([&](float f) {
        guard.check_cancelled();
        report("tree", f);
      });
      log_build(dir.filename().string(), generated, builder.report(), built.stats);
    });
  }

  // 6. More bounces: each a page set gathered from the previous one
  //    (server/engine/bounce_pages.h).
  // Glossy senders keep their lobes in every bounce's set, lit by direct
  // light as in the direct set (docs/gather.md, section 9b).
  std::unique_ptr<SceneGlossyShader> glossy_shader;
  BounceGlossy glossy;
  GlossLookupStats gloss_found;  // of the last bounce set built
  if (options.surfels.glossy_roughness > 0.f && options.bounce.bounces > 1) {
    glossy_shader =
        std::make_unique<SceneGlossyShader>(*session.rays, options.surfels.light_samples, options.surfels.seed);
    glossy.shader = glossy_shader.get();
    glossy.restore = [&](std::span<Surfel> surfels) {
      const GlossLookupStats st = restore_surfel_gloss(*session.rays, options.surfels.glossy_roughness, surfels);
      gloss_found.glossy += st.glossy;
      gloss_found.missed += st.missed;
    };
  }
  for (uint32_t b = 2; b <= options.bounce.bounces; ++b) {
    OpenOptions bounce_options = options;
    bounce_options.bounce.bounces = b;
    dir = ctx.cache_dir / page_set_build_key(scene.content_hash, bounce_options);
    auto next = try_open_existing(dir, ctx);
    if (!next) {
      const std::string stage = "bounce " + std::to_string(b);
      gloss_found = {};
      next = build_or_join(dir, ctx, [&] {
        build_bounce_page_set(
            direct ? *direct : *tree, *tree, options.bounce, options.tree, dir.filename().string(), dir, order_bounds,
            glossy, [&](float f) { report(stage, f); }, cancelled, ctx.staging_quota, table_hook());
      });
      if (glossy.restore) {
        spdlog::info("page set {}: {} glossy senders' lobes restored, {} surfels found no triangle",
                     dir.filename().string(), gloss_found.glossy, gloss_found.missed);
      }
    }
    if (!direct) direct = std::move(tree);
    tree = std::move(next);
  }
  return tree;
}

}  // namespace

std::shared_ptr<SceneSession> open_scene(const fs::path& scene_path, const OpenOptions& options,
                                         const EngineContext& ctx, const StageProgress& progress,
                                         IngestOptions composition, const CancelledFn& cancelled) {
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  auto report = [&](const std::string& stage, float f) {
    if (progress) progress(stage, f);
  };
  options.surfels.validate();
  options.tree.validate();

  // 1. Read the USD scene in the reader process.
  IngestOptions ingest = std::move(composition);
  if (!ctx.python.empty()) ingest.python = ctx.python;
  // Subdivision surfaces are refined until their triangles are within a
  // fraction of the surfel spacing of the limit surface (0: spacing derived
  // later from the area; each mesh is bounded by the spacing target_surfels
  // would have on all the scene's subdivision cages).
  ingest.target_edge_length = options.surfels.spacing;
  ingest.target_surfels = options.surfels.target_surfels;
  // The reader stops (its process killed) when this throws.
  const BuildGuard guard(scene_path.string(), 0, cancelled);
  const auto on_read = [&](const std::string& s, float f) {
    guard.check_cancelled();
    report("read:" + s, f);
  };
  // Charged as it is read, chunk by chunk, before each growth: a scene
  // that cannot fit is refused mid-read (the reader stopped, what was read
  // freed), naming the frame and prim it had reached.
  MemoryCharge read_charge;
  SceneReadMemory on_memory;
  if (ctx.memory) {
    read_charge = ctx.memory->charge(scene_path.string(), "scene being read", 0, ChargeKind::kRead);
    on_memory = [&](uint64_t bytes, const std::string& what) { read_charge.resize(ChargeKind::kRead, bytes, what); };
  }
  bool reused_ingest = false;
  auto scene = std::make_unique<Scene>(
      ctx.ingested ? read_usd_scene_cached(scene_path, ingest, *ctx.ingested, on_read, &reused_ingest, on_memory)
                   : read_usd_scene(scene_path, ingest, on_read, on_memory));
  for (const auto& w : scene->warnings) spdlog::warn("{}: {}", scene_path.string(), w);
  report("read", 1.f);
  auto session = open_read_scene(std::move(scene), options, ctx, progress, cancelled, std::move(read_charge));
  session->info.reused_ingest = reused_ingest;
  session->info.scene_path = scene_path.string();
  session->info.open_seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  return session;
}

std::shared_ptr<SceneSession> open_scene_model(std::unique_ptr<Scene> scene, const OpenOptions& options,
                                               const EngineContext& ctx, const StageProgress& progress,
                                               const CancelledFn& cancelled) {
  MemoryCharge charge;
  if (ctx.memory) charge = ctx.memory->charge(scene->source_path, "scene", 0, ChargeKind::kScene);
  return open_read_scene(std::move(scene), options, ctx, progress, cancelled, std::move(charge));
}

namespace {

// open_scene_model with the charge the read took (ChargeKind::kRead, the
// geometry as read; empty without ctx.memory), which becomes the session's.
std::shared_ptr<SceneSession> open_read_scene(std::unique_ptr<Scene> scene, const OpenOptions& options,
                                              const EngineContext& ctx, const StageProgress& progress,
                                              const CancelledFn& cancelled, MemoryCharge read) {
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  auto report = [&](const std::string& stage, float f) {
    if (progress) progress(stage, f);
  };
  options.surfels.validate();
  options.tree.validate();
  options.bounce.validate();
  options.fog.validate();
  auto session = std::make_shared<SceneSession>();
  session->memory = std::move(read);
  session->scene = std::move(scene);
  Scene& model = *session->scene;

  // 1a. A scene nothing lights renders black: light it if asked, else say so.
  if (!scene_has_light(model)) {
    if (options.default_light) {
      add_default_lights(model);
      model.content_hash += "+default-light/1";
    } else {
      model.warnings.push_back(no_light_warning());
      spdlog::warn("{}: {}", model.source_path, model.warnings.back());
    }
  }

  // 1b. Render in a scene-local frame: positions near a far-away scene keep
  // their float precision (server/scene/render_origin.h). Gather requests
  // arrive in world coordinates and are moved into this frame. Geometry
  // floats cannot hold there is dropped with a warning (to the client in
  // SceneInfo.warnings); far outliers change the frame and the Morton cube
  // (scene_bulk.h), so they are part of the page set's identity.
  const size_t warned = model.warnings.size();
  const LocalFrame frame = rebase_to_local_frame(model);
  for (size_t i = warned; i < model.warnings.size(); ++i) spdlog::warn("{}: {}", model.source_path, model.warnings[i]);
  if (frame.outliers) model.content_hash += "+bulk/1";

  // 2. Ray-tracing structure: needed for surfel shading and primary hits.
  //    Charged to the memory budget first (the geometry as read, the
  //    structure's estimated peak): a scene that cannot fit is refused
  //    before Embree allocates anything. Then the measured size. The
  //    read's charge (the geometry as read) becomes the scene's.
  const uint64_t geometry_bytes = model.geometry_bytes();
  if (ctx.memory) {
    session->memory.reclassify(ChargeKind::kRead, ChargeKind::kScene);
    session->memory.resize(geometry_bytes + estimate_ray_structure_bytes(model),
                           "scene geometry + ray-tracing structure (estimated)");
  }
  session->rays = std::make_unique<RayScene>(*session->scene);
  const uint64_t resident_bytes = geometry_bytes + session->rays->memory_bytes();
  if (ctx.memory) session->memory.resize(resident_bytes, "ray-tracing structure (measured)");
  // The point where scene + BVH memory is complete (scripts/scale_build.sh
  // reads the daemon's peak RSS here): instancing keeps it to the prototypes.
  spdlog::info(
      "ray scene of '{}' built: {} triangles ({} prototypes, {} instances), scene geometry {} bytes, "
      "ray structure {} bytes (peak {} while built)",
      session->scene->source_path, session->scene->triangle_count(), session->scene->prototypes.size(),
      session->scene->instances.size(), geometry_bytes, session->rays->memory_bytes(),
      session->rays->peak_memory_bytes());

  // 2b. Fog: the rays' medium and the gather's volume points (scene_fog.h),
  // before surfels are shaded through it.
  if (!session->scene->volumes.empty()) {
    const float spacing = options.surfels.spacing > 0.f
                              ? options.surfels.spacing
                              : absolute_spacing(*session->scene, options.surfels, scene_area(*session->scene).total);
    prepare_fog(*session, spacing, options.fog);
  }

  // 3. Reuse the page set if this scene + options was built before.
  const std::string key = page_set_build_key(session->scene->content_hash, options);
  session->tree = try_open_existing(ctx.cache_dir / key, ctx);
  session->info.reused_cache = session->tree != nullptr;
  if (!session->tree) {
    storage::create_private_directories(ctx.cache_dir);
    // The build's working memory is charged while it runs, refused before
    // it starts if the budget cannot give it; its sort memory shrinks to
    // what the budget has free (scene_memory.h).
    OpenOptions build_options = options;
    // The page tables it holds are charged beside that as they grow.
    std::function<void(uint64_t)> charge_tables;
    if (ctx.memory) {
      const uint64_t table = estimate_page_table_bytes(expected_surfels(*session->scene, options.surfels));
      build_options.tree.sort_memory_bytes = fit_sort_memory(options, ctx.memory->available(), table);
      const uint64_t estimate = estimate_build_bytes(build_options);
      session->memory.resize(ChargeKind::kBuild, estimate, "page-set build (estimated)");
      charge_tables = [&session, estimate](uint64_t tables) {
        session->memory.resize(ChargeKind::kBuild, estimate + tables, "page-set build (estimated) + page tables");
      };
    }
    session->tree = build_page_sets(*session, build_options, ctx, report, cancelled, charge_tables);
    if (ctx.memory) session->memory.resize(ChargeKind::kBuild, 0, "page-set build");
  }
  // The page table stays in memory while the scene is open: ~2.25 bytes a
  // page (storage/pages/page_table.h): 0.16 GB for the 1.02 G surfels of
  // docs/measurements/2026-11-28-billion-surfels.md.
  if (ctx.memory) {
    session->memory.resize(resident_bytes + session->tree->manifest().pages.memory_bytes(),
                           "scene geometry + ray-tracing structure + page table");
  }

  session->info.scene_id = key;
  session->info.scene_path = session->scene->source_path;
  session->info.triangle_count = session->scene->triangle_count();  // instances expanded
  session->info.tree = session->tree->manifest().stats;
  session->info.open_seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  report("ready", 1.f);
  return session;
}

}  // namespace

}  // namespace pbgi
