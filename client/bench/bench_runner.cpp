#include "client/bench/bench_runner.h"

#include "client/bench/bench_report.h"
#include "client/bench/equal_error.h"
#include "client/bench/plot_runner.h"
#include "client/bench/reference_cache.h"
#include "client/bench/scene_hash.h"
#include "client/bench/stopwatch.h"
#include "client/image/exr_image.h"
#include "client/metrics/perceptual_diff.h"
#include "common/errors.h"
#include "server/ingest/usd_ingest.h"
#include "server/scene/auto_camera.h"
#include "server/volumes/fog_field.h"

#include <fmt/format.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <chrono>
#include <system_error>

namespace pbgi::bench {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

void create_dir(const fs::path& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw IoError(fmt::format("cannot create {}: {}", dir.string(), ec.message()));
}

AovError measure(const std::vector<float>& test, const std::vector<float>& reference,
                 uint32_t width, uint32_t height, const std::string& what) {
  if (test.size() != reference.size() || test.size() != size_t(width) * height * 3)
    throw InvalidArgument(fmt::format("bench: {} has {} values, the reference {} ({}x{} RGB)", what,
                                      test.size(), reference.size(), width, height));
  AovError a;
  a.error = metrics::error_metrics(test.data(), reference.data(), test.size());
  const metrics::PerceptualResult p = metrics::perceptual_diff(test, reference, width, height);
  a.pdiff_pixels = p.pixels_different;
  a.pdiff_fraction = p.fraction_different;
  return a;
}

std::string file_name_of(const std::string& config_name) {
  std::string s = config_name;
  std::replace(s.begin(), s.end(), '/', '_');
  return s;
}

void save_image(const fs::path& file, uint32_t w, uint32_t h, const RenderedAovs& aovs) {
  image::ExrImage img(w, h);
  img.set_rgb("", aovs.beauty);
  if (!aovs.direct.empty()) img.set_rgb("direct", aovs.direct);
  img.set_rgb("indirect", aovs.indirect);
  image::write_exr(file.string(), img);
}

// The reference: from the cache, or rendered and cached.
ReferenceImage obtain_reference(const BenchInput& in, const BenchOptions& o, BenchResult& result) {
  ReferenceOptions ro;
  ro.width = in.width;
  ro.height = in.height;
  ro.spp = o.reference_spp;
  ro.pass_spp = std::max<uint32_t>(1, o.reference_spp / 16);
  ro.max_depth = o.path.max_depth;
  ro.seed = o.reference_seed;
  ReferenceRecord& rec = result.reference;
  rec.spp = ro.spp;
  rec.seed = ro.seed;
  rec.key = reference_cache_key(in.scene_hash, in.camera, ro);
  rec.file = reference_cache_file(o.cache_dir.empty() ? o.out_dir / "cache" : o.cache_dir, rec.key);

  std::string warning;
  if (auto cached = load_cached_reference(rec.file, rec.key, ro.width, ro.height, &warning)) {
    rec.cached = true;
    rec.seconds = cached->seconds;
    rec.cpu_seconds = cached->cpu_seconds;
    if (o.log) o.log(fmt::format("reference: cached {} ({} spp)", rec.file.string(), rec.spp));
    return std::move(cached->image);
  }
  if (!warning.empty()) result.warnings.push_back(warning);

  if (o.log) o.log(fmt::format("reference: path tracing {} spp at {}x{}", ro.spp, ro.width, ro.height));
  ReferenceStats stats;
  const Stopwatch watch;
  const auto progress = [&](const ReferenceProgress& p) {
    if (o.log && p.spp_done < p.spp_total)
      o.log(fmt::format("reference: {}/{} spp, {:.1f} s", p.spp_done, p.spp_total, p.seconds));
    return true;
  };
  ReferenceImage image = render_reference(in.rays, in.camera, ro, progress, &stats);
  rec.seconds = watch.wall_seconds();
  rec.cpu_seconds = watch.cpu_seconds();
  if (stats.nonfinite_samples > 0)
    result.warnings.push_back(fmt::format("reference: {} non-finite samples dropped",
                                          stats.nonfinite_samples));
  store_cached_reference(rec.file, rec.key, image, rec.seconds, rec.cpu_seconds);
  return image;
}

// Renders one configuration and measures it.
BenchRow run_config(const MethodConfig& c, const BenchInput& in, const BuiltState* built,
                    const BuildRecord* build, const ReferenceImage& ref, const BenchOptions& o) {
  const Stopwatch watch;
  const RenderedAovs aovs = c.render(in, built);
  BenchRow row;
  row.render_seconds = watch.wall_seconds();
  row.render_cpu_seconds = watch.cpu_seconds();
  row.method = c.method;
  row.name = c.name;
  row.series = c.series;
  row.build = c.build;
  row.params = c.params;
  row.params.insert(row.params.end(), aovs.stats.begin(), aovs.stats.end());
  row.spp = c.spp;
  row.is_default = c.is_default;
  row.equal_error_point = c.equal_error_point;
  row.default_curve = c.default_curve;
  if (build) {
    row.build_seconds = build->build_seconds + build->load_seconds;
    row.build_cpu_seconds = build->build_cpu_seconds + build->load_cpu_seconds;
  }
  row.total_seconds = row.render_seconds + row.build_seconds;
  row.total_cpu_seconds = row.render_cpu_seconds + row.build_cpu_seconds;
  row.indirect = measure(aovs.indirect, ref.indirect, in.width, in.height, c.name + " indirect");
  row.beauty = measure(aovs.beauty, ref.beauty, in.width, in.height, c.name + " beauty");
  if (o.save_images) save_image(o.out_dir / "images" / (file_name_of(c.name) + ".exr"), in.width, in.height, aovs);
  if (o.log)
    o.log(fmt::format("{}: render {:.3f} s ({:.3f} s CPU), indirect MSE {:.4g} (rel RMSE {:.4f}), beauty MSE {:.4g}{}",
                      c.name, row.render_seconds, row.render_cpu_seconds, row.indirect.error.mse,
                      row.indirect.error.rel_rmse, row.beauty.error.mse, [&] {
                        std::string s;
                        for (const auto& [k, v] : aovs.stats) s += fmt::format(", {} {}", k, v);
                        return s;
                      }()));
  return row;
}

// The path tracer's cost at the error of `target` (null: no such row).
EqualError equal_error(const BenchResult& r, const BenchRow* target, bool indirect) {
  EqualError e;
  e.aov = indirect ? "indirect" : "beauty";
  auto mse = [&](const BenchRow& row) {
    return indirect ? row.indirect.error.mse : row.beauty.error.mse;
  };
  std::vector<SweepPoint> wall, cpu;
  for (const BenchRow& row : r.rows) {
    if (row.method != "path") continue;
    wall.push_back({double(row.spp), row.render_seconds, mse(row)});
    cpu.push_back({double(row.spp), row.render_cpu_seconds, mse(row)});
  }
  if (!target || wall.empty()) {
    e.note = "needs the default PBGI configuration and path-tracer rows";
    return e;
  }
  const BenchRow* def = target;
  e.pbgi_name = def->name;
  e.pbgi_mse = mse(*def);
  e.noise_floor = indirect ? r.reference.noise_mse_indirect : r.reference.noise_mse_beauty;
  e.pbgi_render_seconds = def->render_seconds;
  e.pbgi_total_seconds = def->total_seconds;
  e.pbgi_render_cpu_seconds = def->render_cpu_seconds;
  e.pbgi_total_cpu_seconds = def->total_cpu_seconds;
  auto ratio = [](double a, double b) { return b > 0 ? a / b : 0.0; };
  // Off the default's curve: the default's curve's time at this error (no
  // noise floor: both carry the same one).
  if (!def->default_curve) {
    std::vector<SweepPoint> curve_wall, curve_cpu;
    for (const BenchRow& row : r.rows) {
      if (!row.default_curve) continue;
      curve_wall.push_back({0, row.render_seconds, mse(row)});
      curve_cpu.push_back({0, row.render_cpu_seconds, mse(row)});
    }
    e.default_curve_seconds = front_seconds_at_error(curve_wall, e.pbgi_mse);
    e.default_curve_cpu_seconds = front_seconds_at_error(curve_cpu, e.pbgi_mse);
    e.speedup_over_default = ratio(e.default_curve_seconds, e.pbgi_render_seconds);
    e.speedup_over_default_cpu = ratio(e.default_curve_cpu_seconds, e.pbgi_render_cpu_seconds);
  }
  const EqualErrorPoint p = equal_error_point(wall, e.pbgi_mse, e.noise_floor);
  const EqualErrorPoint pc = equal_error_point(cpu, e.pbgi_mse, e.noise_floor);
  if (!p.valid || !pc.valid) {
    e.note = e.pbgi_mse <= e.noise_floor
                 ? "PBGI's MSE is within the reference's own noise: raise the reference spp"
                 : "no usable path-tracer rows";
    return e;
  }
  e.valid = true;
  e.path_spp = p.spp;
  e.path_seconds = p.seconds;
  e.path_cpu_seconds = pc.seconds;
  e.extrapolated = p.extrapolated;
  e.speedup = ratio(e.path_seconds, e.pbgi_render_seconds);
  e.speedup_including_build = ratio(e.path_seconds, e.pbgi_total_seconds);
  e.speedup_cpu = ratio(e.path_cpu_seconds, e.pbgi_render_cpu_seconds);
  return e;
}

void analyse(BenchResult& r) {
  // Pareto flags over all rows, render time against MSE.
  std::vector<double> t, ei, eb;
  for (const BenchRow& row : r.rows) {
    t.push_back(row.render_seconds);
    ei.push_back(row.indirect.error.mse);
    eb.push_back(row.beauty.error.mse);
  }
  const std::vector<bool> pi = pareto_optimal(t, ei), pb = pareto_optimal(t, eb);
  for (size_t i = 0; i < r.rows.size(); ++i) {
    r.rows[i].pareto_indirect = pi[i];
    r.rows[i].pareto_beauty = pb[i];
  }
  // The reference's own variance, from the most-sampled path-tracer row:
  // MSE(N spp vs reference) ~ s^2/N + s^2/M, so s^2/M ~ MSE_N * N / M.
  const BenchRow* most = nullptr;
  for (const BenchRow& row : r.rows)
    if (row.method == "path" && (!most || row.spp > most->spp)) most = &row;
  if (most && r.reference.spp > 0) {
    const double scale = double(most->spp) / (double(most->spp) + r.reference.spp);
    r.reference.noise_mse_indirect = most->indirect.error.mse * scale;
    r.reference.noise_mse_beauty = most->beauty.error.mse * scale;
  }
  const auto def = std::find_if(r.rows.begin(), r.rows.end(),
                                [](const BenchRow& row) { return row.is_default; });
  const BenchRow* default_row = def == r.rows.end() ? nullptr : &*def;
  r.equal_indirect = equal_error(r, default_row, true);
  r.equal_beauty = equal_error(r, default_row, false);
  for (const BenchRow& row : r.rows)
    if (row.equal_error_point) r.equal_points.push_back(equal_error(r, &row, true));
}

}  // namespace

MethodPlan bench_plan(const BenchOptions& options) {
  MethodPlan plan = pbgi_plan(options.pbgi);
  plan.append(path_plan(options.path));
  plan.validate();
  return plan;
}

BenchResult run_bench(const Scene& scene, const BenchOptions& o) {
  const auto t_start = Clock::now();
  // 1. Options, camera, directories, ray structure.
  o.validate();
  const MethodPlan plan = bench_plan(o);
  const Camera camera = resolve_camera(scene, o.camera, float(o.width) / float(o.height));
  const fs::path work_dir = o.work_dir.empty() ? o.out_dir / "work" : o.work_dir;
  create_dir(o.out_dir);
  create_dir(work_dir);
  if (o.save_images) create_dir(o.out_dir / "images");
  const std::string scene_hash = scene_model_hash(scene);
  RayScene rays(scene);
  // Fog grids as the PBGI method's open_scene_model applies them (its
  // OpenOptions keep the default FogOptions), so the reference sees the
  // same extinction and single scattering.
  const auto fog = std::make_shared<FogField>(scene, FogOptions{});
  if (!fog->empty()) rays.set_medium(fog);
  const BenchInput in{scene, scene_hash, rays, camera, o.width, o.height, work_dir,
                      o.page_cache_bytes};

  BenchResult result;
  result.scene = scene.source_path.empty() ? "(in memory)" : scene.source_path;
  result.scene_hash = scene_hash;
  result.camera = camera.prim_path;
  result.width = o.width;
  result.height = o.height;
  result.max_depth = o.path.max_depth;
  result.threads = static_cast<uint32_t>(tbb::this_task_arena::max_concurrency());

  // 2. The reference.
  const ReferenceImage ref = obtain_reference(in, o, result);
  if (o.save_images) {
    image::ExrImage img(ref.width, ref.height);
    img.set_rgb("", ref.beauty);
    img.set_rgb("direct", ref.direct);
    img.set_rgb("indirect", ref.indirect);
    image::write_exr((o.out_dir / "images" / "reference.exr").string(), img);
  }

  // 3. Builds, each with its configurations.
  for (const BuildSpec& b : plan.builds) {
    BuildRecord rec;
    rec.name = b.name;
    rec.params = b.params;
    if (o.log) o.log(fmt::format("{}: building", b.name));
    const Stopwatch build_watch;
    std::unique_ptr<BuiltState> built = b.build(in);
    rec.build_seconds = build_watch.wall_seconds();
    rec.build_cpu_seconds = build_watch.cpu_seconds();
    const Stopwatch load_watch;
    built->load();
    rec.load_seconds = load_watch.wall_seconds();
    rec.load_cpu_seconds = load_watch.cpu_seconds();
    rec.facts = built->describe();
    if (o.log)
      o.log(fmt::format("{}: build {:.3f} s, load {:.3f} s", b.name, rec.build_seconds,
                        rec.load_seconds));
    for (const auto& [k, v] : rec.facts)
      if (k == "cache_evictions" && v != "0")
        result.warnings.push_back(fmt::format(
            "{}: the page set does not fit the page cache ({} evictions while loading): render "
            "times include page loads; raise page_cache_bytes",
            b.name, v));
    for (const MethodConfig& c : plan.configs)
      if (c.build == b.name)
        result.rows.push_back(run_config(c, in, built.get(), &rec, ref, o));
    result.builds.push_back(std::move(rec));
  }
  // 4. Configurations without a build.
  for (const MethodConfig& c : plan.configs)
    if (c.build.empty()) result.rows.push_back(run_config(c, in, nullptr, nullptr, ref, o));

  // 5. Pareto flags, reference noise, equal-error figure.
  analyse(result);
  std::error_code ec;
  if (o.work_dir.empty()) fs::remove(work_dir, ec);  // only if empty: never someone's files

  // 6. Outputs.
  result.json_file = o.out_dir / "bench.json";
  result.csv_file = o.out_dir / "bench.csv";
  result.wall_seconds = seconds_since(t_start);
  write_text_file(result.csv_file, bench_csv(result));
  write_text_file(result.json_file, bench_json(result));
  if (o.plot) {
    const fs::path png = o.out_dir / "bench.png";
    const PlotOutcome plot = run_plot_script(o.python, o.plot_script, result.json_file, png);
    if (plot.status == PlotOutcome::Status::Written)
      result.plot_file = png;
    else
      result.warnings.push_back("plot: " + plot.message);
  }
  return result;
}

BenchResult run_bench_usd(const fs::path& usd_path, const BenchOptions& options) {
  IngestOptions ingest;
  if (!options.python.empty()) ingest.python = options.python;
  if (options.log) options.log(fmt::format("reading {}", usd_path.string()));
  const Scene scene = read_usd_scene(usd_path, ingest);
  return run_bench(scene, options);
}

}  // namespace pbgi::bench
