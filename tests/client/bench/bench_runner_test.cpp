#include "client/bench/bench_runner.h"

#include "common/errors.h"
#include "tests/stability/stability_scenes.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <set>
#include <unistd.h>

namespace pbgi::bench {
namespace {

namespace fs = std::filesystem;

std::string read_file(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

// A sweep small enough for a unit test: 24x24, one 2k-surfel build, two
// settings for each of PBGI and FPBGI and the default one antialiased, a
// second build with k-means-quantized payloads (LUT of 64) rendered by both
// at both settings, the path tracer at 1..16 spp, a 256-spp reference.
BenchOptions tiny_options(const fs::path& out) {
  BenchOptions o;
  o.width = 24;
  o.height = 24;
  o.pbgi.target_surfels = {2000};
  o.pbgi.microbuffer_resolutions = {4, 8};
  o.pbgi.max_solid_angles = {0.1f};
  o.pbgi.default_target_surfels = 2000;
  o.pbgi.default_microbuffer_resolution = 8;
  o.pbgi.default_max_solid_angle = 0.1f;
  o.pbgi.pixel_samples = 1;  // the sweep at one camera ray, the extra render at 4
  o.pbgi.extra_pixel_samples = {4};
  // No silhouette samples: against this tiny sweep's 256-spp reference
  // they leave PBGI's beauty within the reference's own noise, where no
  // equal-error figure exists.
  o.pbgi.edge_samples = 0;
  o.pbgi.methods = {GatherMethod::kPbgi, GatherMethod::kFpbgi};
  // The widest far/near split: at 24x24 the clusters are so large against
  // the box that the automatic one leaves every node near, and FPBGI would
  // gather exactly as PBGI.
  o.pbgi.fpbgi_epsilon = GatherOptions::kMaxEpsilon;
  o.pbgi.payloads = {PayloadSpec{}, parse_payload_spec("kmeans-sh:64")};
  o.path.max_spp = 16;
  o.reference_spp = 256;
  o.out_dir = out;
  return o;
}

class BenchRunner : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    out_ = new fs::path(fs::path(PBGI_TEST_BINARY_DIR) / "bench-scratch" /
                        ("runner-" + std::to_string(::getpid())));
    fs::remove_all(*out_);
    scene_ = new Scene(stability::cornell_box());
    result_ = new BenchResult(run_bench(*scene_, tiny_options(*out_)));
  }
  static void TearDownTestSuite() {
    fs::remove_all(*out_);
    delete result_;
    delete scene_;
    delete out_;
  }
  static const BenchRow* row(const std::string& name) {
    for (const BenchRow& r : result_->rows)
      if (r.name == name) return &r;
    return nullptr;
  }

  static fs::path* out_;
  static Scene* scene_;
  static BenchResult* result_;
};
fs::path* BenchRunner::out_ = nullptr;
Scene* BenchRunner::scene_ = nullptr;
BenchResult* BenchRunner::result_ = nullptr;

const std::vector<std::string> kExpectedRows{"pbgi/s2k/mb4/sa0.1",
                                            "pbgi/s2k/mb8/sa0.1",
                                            "fpbgi/s2k/mb4/sa0.1",
                                            "fpbgi/s2k/mb8/sa0.1",
                                            "pbgi/s2k/mb8/sa0.1/px4",
                                            "pbgi/s2k/kmeans-sh:64/mb4/sa0.1",
                                            "pbgi/s2k/kmeans-sh:64/mb8/sa0.1",
                                            "fpbgi/s2k/kmeans-sh:64/mb4/sa0.1",
                                            "fpbgi/s2k/kmeans-sh:64/mb8/sa0.1",
                                            "path/spp1",
                                            "path/spp2",
                                            "path/spp4",
                                            "path/spp8",
                                            "path/spp16"};

const BuildRecord* build_of(const BenchResult& r, const std::string& name) {
  for (const BuildRecord& b : r.builds)
    if (b.name == name) return &b;
  return nullptr;
}

TEST_F(BenchRunner, MeasuresEveryConfigurationOfTheSweep) {
  const BenchResult& r = *result_;
  ASSERT_EQ(r.rows.size(), kExpectedRows.size());
  for (size_t i = 0; i < kExpectedRows.size(); ++i) EXPECT_EQ(r.rows[i].name, kExpectedRows[i]);
  ASSERT_EQ(r.builds.size(), 2u);
  EXPECT_EQ(r.builds[0].name, "pbgi/s2k");
  EXPECT_EQ(r.builds[1].name, "pbgi/s2k/kmeans-sh:64");
  EXPECT_GT(r.builds[0].build_seconds, 0.0);
  for (const BenchRow& row : r.rows) {
    SCOPED_TRACE(row.name);
    EXPECT_GT(row.render_seconds, 0.0);
    EXPECT_GT(row.render_cpu_seconds, 0.0);
    EXPECT_GT(row.indirect.error.mse, 0.0);
    EXPECT_GT(row.beauty.error.mse, 0.0);
    EXPECT_EQ(row.indirect.error.values, 24u * 24u * 3u);
    EXPECT_EQ(row.indirect.error.nonfinite, 0u);
    if (row.method != "path") {
      const BuildRecord* b = build_of(r, row.build);
      ASSERT_NE(b, nullptr);
      EXPECT_DOUBLE_EQ(row.build_seconds, b->build_seconds + b->load_seconds);
      EXPECT_DOUBLE_EQ(row.total_seconds, row.render_seconds + row.build_seconds);
    } else {
      EXPECT_EQ(row.build_seconds, 0.0);
    }
  }
  EXPECT_TRUE(row("pbgi/s2k/mb8/sa0.1")->is_default);
  EXPECT_FALSE(row("pbgi/s2k/mb4/sa0.1")->is_default);
  EXPECT_FALSE(row("pbgi/s2k/mb8/sa0.1/px4")->is_default);
  // Four camera rays per pixel: the beauty's aliasing against the
  // pixel-averaged reference shrinks.
  EXPECT_LT(row("pbgi/s2k/mb8/sa0.1/px4")->beauty.error.mse,
            row("pbgi/s2k/mb8/sa0.1")->beauty.error.mse);
  EXPECT_EQ(r.reference.spp, 256u);
  EXPECT_FALSE(r.reference.cached);
  EXPECT_TRUE(fs::exists(r.reference.file));
}

TEST_F(BenchRunner, PathTracerErrorFallsWithSamples) {
  double last_indirect = INFINITY, last_beauty = INFINITY;
  for (const char* name : {"path/spp1", "path/spp2", "path/spp4", "path/spp8", "path/spp16"}) {
    const BenchRow* r = row(name);
    ASSERT_NE(r, nullptr) << name;
    EXPECT_LT(r->indirect.error.mse, last_indirect) << name;
    EXPECT_LT(r->beauty.error.mse, last_beauty) << name;
    last_indirect = r->indirect.error.mse;
    last_beauty = r->beauty.error.mse;
  }
  // Roughly the Monte Carlo rate over 16x the samples (the reference's own
  // noise flattens the end a little).
  EXPECT_LT(row("path/spp16")->indirect.error.mse, row("path/spp1")->indirect.error.mse / 6);
  EXPECT_GT(result_->reference.noise_mse_indirect, 0.0);
  EXPECT_LT(result_->reference.noise_mse_indirect, row("path/spp16")->indirect.error.mse);
}

TEST_F(BenchRunner, FactorizedAndQuantizedPayloadsAreCurvesOfTheirOwn) {
  // Each method and codec renders its own images (a flag not reaching the
  // gather or the build would give the same images as plain PBGI) with a
  // finite error, in series of their own.
  const BenchRow* pbgi = row("pbgi/s2k/mb8/sa0.1");
  ASSERT_NE(pbgi, nullptr);
  std::set<std::string> series;
  for (const char* name : {"fpbgi/s2k/mb8/sa0.1", "pbgi/s2k/kmeans-sh:64/mb8/sa0.1",
                           "fpbgi/s2k/kmeans-sh:64/mb8/sa0.1"}) {
    SCOPED_TRACE(name);
    const BenchRow* r = row(name);
    ASSERT_NE(r, nullptr);
    EXPECT_TRUE(std::isfinite(r->indirect.error.mse));
    EXPECT_GT(r->indirect.error.mse, 0.0);
    EXPECT_NE(r->indirect.error.mse, pbgi->indirect.error.mse);
    // Still the same light transport: within 3x of PBGI's error.
    EXPECT_LT(r->indirect.error.mse, 3 * pbgi->indirect.error.mse);
    EXPECT_NE(r->series, pbgi->series);
    series.insert(r->series);
  }
  EXPECT_EQ(series.size(), 3u);
  EXPECT_EQ(row("fpbgi/s2k/mb8/sa0.1")->method, "fpbgi");
  EXPECT_EQ(row("pbgi/s2k/kmeans-sh:64/mb8/sa0.1")->build, "pbgi/s2k/kmeans-sh:64");
  // The two kmeans-sh microbuffers are one curve per method.
  EXPECT_EQ(row("pbgi/s2k/kmeans-sh:64/mb4/sa0.1")->series,
            row("pbgi/s2k/kmeans-sh:64/mb8/sa0.1")->series);
}

TEST_F(BenchRunner, MatchesThePathTracerAtEveryMethodsError) {
  // One equal-error point per configuration at the default surfels, cut and
  // pixel samples: the four gather settings of each build.
  const BenchResult& r = *result_;
  ASSERT_EQ(r.equal_points.size(), 8u);
  for (const EqualError& e : r.equal_points) {
    SCOPED_TRACE(e.pbgi_name);
    const BenchRow* source = row(e.pbgi_name);
    ASSERT_NE(source, nullptr);
    EXPECT_TRUE(source->equal_error_point);
    EXPECT_EQ(e.aov, "indirect");
    EXPECT_DOUBLE_EQ(e.pbgi_mse, source->indirect.error.mse);
    ASSERT_TRUE(e.valid) << e.note;
    EXPECT_NEAR(e.speedup_cpu, e.path_cpu_seconds / e.pbgi_render_cpu_seconds,
                1e-9 * e.speedup_cpu);
    // Only configurations off the default's curve (plain PBGI, derived
    // payloads) are compared with it.
    if (source->default_curve) {
      EXPECT_EQ(e.default_curve_seconds, 0.0);
    } else if (e.default_curve_cpu_seconds > 0) {
      EXPECT_NEAR(e.speedup_over_default_cpu, e.default_curve_cpu_seconds / e.pbgi_render_cpu_seconds,
                  1e-9 * e.speedup_over_default_cpu);
    }
  }
  EXPECT_TRUE(row("pbgi/s2k/mb4/sa0.1")->default_curve);
  EXPECT_FALSE(row("fpbgi/s2k/mb4/sa0.1")->default_curve);
  EXPECT_FALSE(row("pbgi/s2k/kmeans-sh:64/mb8/sa0.1")->default_curve);
  EXPECT_FALSE(row("pbgi/s2k/mb8/sa0.1/px4")->equal_error_point);
}

TEST_F(BenchRunner, ComputesTheEqualErrorFigureAndParetoFront) {
  const BenchResult& r = *result_;
  for (const EqualError* e : {&r.equal_indirect, &r.equal_beauty}) {
    SCOPED_TRACE(e->aov);
    ASSERT_TRUE(e->valid);
    EXPECT_EQ(e->pbgi_name, "pbgi/s2k/mb8/sa0.1");
    EXPECT_GT(e->path_spp, 0.0);
    EXPECT_NEAR(e->speedup, e->path_seconds / e->pbgi_render_seconds, 1e-9 * e->speedup);
    EXPECT_LT(e->speedup_including_build, e->speedup);
    EXPECT_GT(e->path_cpu_seconds, 0.0);
    EXPECT_NEAR(e->speedup_cpu, e->path_cpu_seconds / e->pbgi_render_cpu_seconds,
                1e-9 * e->speedup_cpu);
    EXPECT_GT(e->noise_floor, 0.0);
  }
  EXPECT_DOUBLE_EQ(r.equal_indirect.pbgi_mse, row("pbgi/s2k/mb8/sa0.1")->indirect.error.mse);
  // The fastest configuration and the most accurate one are always optimal.
  size_t fastest = 0, best = 0;
  for (size_t i = 0; i < r.rows.size(); ++i) {
    if (r.rows[i].render_seconds < r.rows[fastest].render_seconds) fastest = i;
    if (r.rows[i].indirect.error.mse < r.rows[best].indirect.error.mse) best = i;
  }
  EXPECT_TRUE(r.rows[fastest].pareto_indirect);
  EXPECT_TRUE(r.rows[best].pareto_indirect);
}

TEST_F(BenchRunner, WritesJsonAndCsv) {
  const std::string json = read_file(*out_ / "bench.json");
  const std::string csv = read_file(*out_ / "bench.csv");
  EXPECT_NE(json.find("\"schema\": \"pbgi.bench/1\""), std::string::npos);
  EXPECT_NE(json.find("\"equal_error\""), std::string::npos);
  EXPECT_NE(json.find("\"speedup_cpu\""), std::string::npos);
  EXPECT_NE(json.find("\"equal_error_points\""), std::string::npos);
  EXPECT_NE(json.find("\"speedup_over_default\""), std::string::npos);
  for (const auto& name : kExpectedRows) {
    EXPECT_NE(json.find("\"name\": \"" + name + "\""), std::string::npos) << name;
    EXPECT_NE(csv.find("," + name + ","), std::string::npos) << name;
  }
  // Header + one line per row; parameter columns from both methods.
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 1 + long(kExpectedRows.size()));
  const std::string header = csv.substr(0, csv.find('\n'));
  for (const char* col : {"gather_method", "payload_codec", "clusters", "epsilon", "target_surfels", "microbuffer_resolution", "max_solid_angle", "spp",
                          "render_seconds", "total_seconds", "indirect_mse", "indirect_psnr",
                          "indirect_relmse", "indirect_pdiff_pixels", "beauty_mse",
                          "pareto_indirect"})
    EXPECT_NE(header.find(col), std::string::npos) << col;
}

TEST_F(BenchRunner, DrawsThePlot) {
  const BenchResult& r = *result_;
  if (r.plot_file.empty()) {
    for (const auto& w : r.warnings)
      if (w.find("no matplotlib") != std::string::npos) GTEST_SKIP() << w;
    FAIL() << "no plot and no reason given";
  }
  const std::string png = read_file(r.plot_file);
  ASSERT_GT(png.size(), 8u);
  EXPECT_EQ(png.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
}

TEST_F(BenchRunner, ReusesTheCachedReference) {
  BenchOptions o = tiny_options(*out_ / "again");
  o.cache_dir = result_->reference.file.parent_path();
  o.pbgi.microbuffer_resolutions = {8};
  o.pbgi.extra_pixel_samples.clear();
  o.pbgi.methods = {GatherMethod::kPbgi};
  o.pbgi.payloads = {PayloadSpec{}};
  o.path.max_spp = 2;
  o.plot = false;
  const BenchResult again = run_bench(*scene_, o);
  EXPECT_TRUE(again.reference.cached);
  EXPECT_EQ(again.reference.file, result_->reference.file);
  // Deterministic renders against the same reference: the same errors.
  ASSERT_EQ(again.rows.size(), 3u);
  EXPECT_DOUBLE_EQ(again.rows[0].indirect.error.mse, row("pbgi/s2k/mb8/sa0.1")->indirect.error.mse);
  EXPECT_DOUBLE_EQ(again.rows[2].beauty.error.mse, row("path/spp2")->beauty.error.mse);
}

TEST_F(BenchRunner, RendersPbgiInTheSessionsFrame) {
  // open_scene_model moves a scene away from the origin into its local
  // frame; PBGI must render with the camera moved along (once it used the
  // world-space camera, and every PBGI image looked past the geometry).
  BenchOptions o = tiny_options(*out_ / "moved");
  o.pbgi.microbuffer_resolutions = {8};
  o.pbgi.methods = {GatherMethod::kPbgi};
  o.pbgi.payloads = {PayloadSpec{}};
  o.pbgi.extra_pixel_samples.clear();
  o.path.max_spp = 2;
  o.plot = false;
  const BenchResult moved = run_bench(stability::cornell_box_in_float_world(V3f(40, -24, 16)), o);
  ASSERT_EQ(moved.rows.size(), 3u);
  EXPECT_EQ(moved.rows[0].name, "pbgi/s2k/mb8/sa0.1");
  const double at_origin = row("pbgi/s2k/mb8/sa0.1")->indirect.error.mse;
  EXPECT_LT(moved.rows[0].indirect.error.mse, 1.5 * at_origin);
  // The absolute check: the camera in the wrong frame misses the box for
  // both, and its error (6e-3) exceeds the path tracer's at 16 spp.
  EXPECT_LT(moved.rows[0].indirect.error.mse, row("path/spp16")->indirect.error.mse);
  EXPECT_LT(at_origin, row("path/spp16")->indirect.error.mse);
  EXPECT_LT(moved.rows[0].beauty.error.mse, 1.5 * row("pbgi/s2k/mb8/sa0.1")->beauty.error.mse);
}

TEST(BenchOptions, RejectsInconsistentSweeps) {
  BenchOptions o = tiny_options("/tmp/unused");
  EXPECT_NO_THROW(o.validate());
  BenchOptions a = o;
  a.pbgi.default_max_solid_angle = 0.03f;  // not swept
  EXPECT_THROW(a.validate(), InvalidArgument);
  BenchOptions b = o;
  b.reference_spp = 8;  // less than the sweep's 16
  EXPECT_THROW(b.validate(), InvalidArgument);
  BenchOptions c = o;
  c.reference_seed = c.path.seed;
  EXPECT_THROW(c.validate(), InvalidArgument);
  BenchOptions d = o;
  d.pbgi.microbuffer_resolutions = {3};
  EXPECT_THROW(d.validate(), InvalidArgument);
  BenchOptions e = o;
  e.out_dir.clear();
  EXPECT_THROW(e.validate(), InvalidArgument);
  BenchOptions f = o;
  f.pbgi.extra_pixel_samples = {1};  // the main sweep's count again
  EXPECT_THROW(f.validate(), InvalidArgument);
  BenchOptions g = o;
  g.pbgi.methods = {GatherMethod::kFpbgi};  // the default method (PBGI) not swept
  EXPECT_THROW(g.validate(), InvalidArgument);
  BenchOptions h = o;
  h.pbgi.methods = {GatherMethod::kPbgi, GatherMethod::kPbgi};
  EXPECT_THROW(h.validate(), InvalidArgument);
  BenchOptions i = o;
  i.pbgi.payloads.push_back(parse_payload_spec("kmeans-sh:64"));  // repeated
  EXPECT_THROW(i.validate(), InvalidArgument);
  BenchOptions j = o;
  j.pbgi.fpbgi_clusters = 0;
  EXPECT_THROW(j.validate(), InvalidArgument);
  BenchOptions k = o;
  k.pbgi.payloads.clear();
  EXPECT_THROW(k.validate(), InvalidArgument);
  EXPECT_NO_THROW(quick_bench_options().pbgi.validate());
}

TEST(BenchPlan, ListsEveryMethodWithUniqueNames) {
  const MethodPlan plan = bench_plan(BenchOptions{});
  EXPECT_EQ(plan.builds.size(), 3u);  // 50k, 200k surfels; 200k with kmeans-sh:1024
  // 2 methods x 2 budgets x 3 microbuffers x 4 cuts, 1 antialiased, 2
  // methods x 3 microbuffers of kmeans-sh, the path tracer at 1..256 spp.
  EXPECT_EQ(plan.configs.size(), 48u + 1u + 6u + 9u);
  int defaults = 0;
  for (const MethodConfig& c : plan.configs) defaults += c.is_default;
  EXPECT_EQ(defaults, 1);
  MethodPlan dup = plan;
  dup.configs.push_back(plan.configs.front());
  EXPECT_THROW(dup.validate(), InvalidArgument);
}

TEST(BenchRunnerErrors, NamesAMissingCamera) {
  BenchOptions o = tiny_options(fs::path(PBGI_TEST_BINARY_DIR) / "bench-scratch" / "nocam");
  o.camera = "/Nope";
  try {
    run_bench(stability::cornell_box(), o);
    FAIL() << "expected NotFound";
  } catch (const NotFound& e) {
    EXPECT_NE(std::string(e.what()).find("/Camera"), std::string::npos) << e.what();
  }
  fs::remove_all(o.out_dir);
}

}  // namespace
}  // namespace pbgi::bench
