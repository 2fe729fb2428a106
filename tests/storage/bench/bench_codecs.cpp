// bench_codecs: what the stored node payloads cost and save on a real scene
// (issue 5, "measure against the paper"). Every variant is a real page-set
// build (build_page_set, the streaming build with its tree.payload_codec
// option), read back through PageSetReader as the daemon would.
//
//   bench_codecs --scene scenes/cornell.usda --surfels 5000000 --image 256 --lut 100 --lut 1000 --lut 10000
//
// 1. Surfels: the scene sampled at --surfels and shaded with direct light
//    (cached in --cache so repeated runs skip it).
// 2. Reference: the `derived` page set (exact payloads, V2 pages), rendered
//    through PBGI (indirect and beauty AOVs).
// 3. Each variant (float32-sh stored, kmeans-sh at each --lut): built with
//    the same surfels and options, its bytes measured from the page headers,
//    rendered again from disk.
// 4. The table: page-set bytes, payload bytes, ratios, LUT and build times,
//    PSNR of the images against the reference.
// Glossy senders (a scene with glossy materials, e.g. scenes/cornell_gold.usda)
// get wavelet radiance in every variant (exact, threshold 0); each
// --wavelet-threshold adds a variant with derived SH payloads and that
// threshold, and a second table compares glossy bytes and PSNR:
//   bench_codecs --scene scenes/cornell_gold.usda --surfels 5000000 --lut 1000
//       --wavelet-threshold 0.01 --wavelet-threshold 0.1   (one command)
#include "common/errors.h"
#include "server/ingest/usd_ingest.h"
#include "server/render/tile_renderer.h"
#include "server/scene/ray_scene.h"
#include "server/surfels/glossy_shading.h"
#include "server/surfels/surfels.h"
#include "storage/cache/page_cache.h"
#include "storage/codecs/payload_codec.h"
#include "storage/format/page_frame.h"
#include "storage/pages/page_encoding.h"
#include "storage/pages/page_set.h"
#include "storage/tree/tree_builder.h"
#include "tests/storage/bench/page_parts.h"

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <vector>

namespace pbgi {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

struct Args {
  fs::path scene = fs::path(PBGI_TEST_SOURCE_DIR) / "scenes/cornell.usda";
  uint64_t surfels = 5000000;
  uint32_t image = 256;
  uint32_t leaf_size = 4;
  double fraction = 0.02;
  std::vector<uint32_t> luts = {100, 1000, 10000};
  fs::path cache = "/tmp/pbgi_bench_codecs";
  fs::path sets = "/tmp/pbgi_bench_codecs/sets";  // page sets built here (replaced)
  std::string camera = "/Camera";
  bool render = true;
  uint32_t threads = 0;  // 0: all cores
  // Glossy senders: wavelet thresholds to measure (each a variant with
  // derived SH payloads); the reference and the SH variants store exact
  // (threshold 0) glossy radiance.
  std::vector<float> wavelet_thresholds;
  uint32_t glossy_resolution = 16;
  // Leaf formats (storage/tree/page_records.h) besides relative, the
  // paper's format B: each repeats float32-sh and every LUT in that format.
  std::vector<std::string> leaf_formats;
};

// 1. Surfels of the scene, from the cache when present.
std::vector<Surfel> scene_surfels(const Args& a, const Scene& scene, const RayScene& rays) {
  // v2: surfels carry their glossy lobe (storage/tree/surfel.h).
  const fs::path file = a.cache / fmt::format("surfels_v2_{}_{}.bin", a.scene.stem().string(), a.surfels);
  if (fs::exists(file)) {
    std::ifstream in(file, std::ios::binary);
    uint64_t n = 0;
    in.read(reinterpret_cast<char*>(&n), 8);
    std::vector<Surfel> s(n);
    in.read(reinterpret_cast<char*>(s.data()), std::streamsize(n * sizeof(Surfel)));
    if (in) return s;
  }
  SurfelOptions o;
  o.target_surfels = a.surfels;
  auto t0 = Clock::now();
  std::vector<Surfel> s = sample_surfels(scene, o);
  shade_direct(rays, o, s);
  std::cerr << fmt::format("surfels: {} sampled and shaded in {:.1f} s\n", s.size(), since(t0));
  fs::create_directories(a.cache);
  std::ofstream out(file, std::ios::binary);
  const uint64_t n = s.size();
  out.write(reinterpret_cast<const char*>(&n), 8);
  out.write(reinterpret_cast<const char*>(s.data()), std::streamsize(n * sizeof(Surfel)));
  return s;
}

struct Image {
  std::vector<float> indirect, beauty;
};

Image render(const RayScene& rays, const tree::TreeSource& tree, const Camera& cam, uint32_t size) {
  RenderOptions o;
  o.light_samples = 4;
  const TileAovs t = render_tile(rays, tree, cam, size, size, {0, 0, size, size}, o);
  return {t.indirect, t.beauty};
}

// PSNR with the reference's peak value as the signal maximum.
double psnr(const std::vector<float>& ref, const std::vector<float>& img) {
  double peak = 0, se = 0;
  for (size_t i = 0; i < ref.size(); ++i) {
    peak = std::max(peak, double(ref[i]));
    se += std::pow(double(ref[i]) - img[i], 2);
  }
  const double mse = se / double(ref.size());
  return mse > 0 ? 10 * std::log10(peak * peak / mse) : INFINITY;
}

struct Row {
  std::string name;
  storage::LeafFormat leaf_format = storage::LeafFormat::kRelative;
  uint64_t file_bytes = 0, payload_bytes = 0;
  uint64_t pages = 0;
  double build_seconds = 0, lut_seconds = 0;
  double load_seconds = 0;  // read, verify and decode every page once (no cache)
  uint64_t lut_sample = 0;
  uint32_t lut_entries = 0;
  double psnr_indirect = INFINITY, psnr_beauty = INFINITY;
  // Glossy radiance: stored bytes, and what the coded nodes' cube maps
  // take as dense float32 (every node's whole vector, no coding).
  uint64_t glossy_bytes = 0, glossy_dense_bytes = 0, glossy_surfels = 0;
  double glossy_shade_seconds = 0;
};

// Sum of the payload arrays of every page (decoded: V8 headers do not
// store their size).
uint64_t payload_bytes(const fs::path& dir, const storage::Manifest& m) {
  uint64_t total = 0;
  test::for_each_page_parts(dir, m, [&](const storage::PageParts& p, size_t) { total += p.albedo - p.payloads; });
  return total;
}

// Builds one variant's page set from `surfels` and measures it.
Row build_variant(const Args& a, const std::vector<Surfel>& surfels, const std::string& name,
                  tree::PayloadCodecOption codec, uint32_t lut, const fs::path& dir,
                  const storage::GlossyShader& glossy, float wavelet_threshold = 0.f,
                  storage::LeafFormat leaf_format = storage::LeafFormat::kRelative) {
  tree::BuildOptions o;
  o.leaf_size = a.leaf_size;
  o.leaf_format = leaf_format;
  o.payload_codec = codec;
  o.lut_entries = lut;
  o.lut_sample_fraction = a.fraction;
  o.glossy_resolution = a.glossy_resolution;
  o.wavelet_threshold = wavelet_threshold;
  fs::remove_all(dir);
  Row r{name, leaf_format};
  storage::BuildReport report;
  const auto t0 = Clock::now();
  const storage::Manifest m = storage::build_page_set(surfels, o, "bench-" + name, dir, {}, &report, &glossy);
  r.build_seconds = since(t0);
  r.glossy_bytes = report.glossy.bytes;
  r.glossy_dense_bytes = report.glossy.nodes * storage::CubeLayout{a.glossy_resolution}.floats() * sizeof(float);
  r.glossy_surfels = report.glossy.glossy_surfels;
  r.glossy_shade_seconds = report.glossy.shade_seconds;
  r.file_bytes = m.stats.file_bytes + fs::file_size(dir / storage::kManifestFileName);
  r.payload_bytes = payload_bytes(dir, m) + m.codec_state.size();  // the LUT counts as payload
  r.pages = m.stats.page_count;
  r.lut_seconds = report.lut_seconds;
  r.lut_sample = report.lut_sample_surfels;
  r.lut_entries = report.lut_entries;
  {
    // Every page loaded once, as a cold cache would (the file itself is
    // likely in the OS page cache right after the build).
    const storage::PageSetReader reader(dir, nullptr);
    const auto t1 = Clock::now();
    for (uint32_t id = 0; id < m.stats.page_count; ++id) (void)reader.page(id);
    r.load_seconds = since(t1);
  }
  std::cerr << fmt::format("  {}: {} nodes, {} pages, {:.1f} MB, build {:.1f} s (LUT {:.1f} s: {} entries from {} "
                           "surfels; glossy: {} surfels, {:.2f} MB in {} pages, {}/{} face blocks kept, lobes "
                           "{:.1f} s), load {:.2f} s\n",
                           name, m.stats.node_count, r.pages, double(r.file_bytes) / 1e6, r.build_seconds,
                           r.lut_seconds, r.lut_entries, r.lut_sample, r.glossy_surfels, double(r.glossy_bytes) / 1e6,
                           report.glossy.pages, report.glossy.kept_blocks,
                           report.glossy.kept_blocks + report.glossy.dropped_blocks, r.glossy_shade_seconds,
                           r.load_seconds);
  return r;
}

int run(const Args& a) {
  // 1. Scene and surfels.
  auto t0 = Clock::now();
  const Scene scene = read_usd_scene(a.scene, {});
  const RayScene rays(scene);
  const Camera* cam = scene.find_camera(a.camera);
  if (!cam) throw NotFound("camera " + a.camera);
  const std::vector<Surfel> surfels = scene_surfels(a, scene, rays);
  const SurfelOptions surfel_defaults;
  const SceneGlossyShader glossy(rays, surfel_defaults.light_samples, surfel_defaults.seed);
  std::cerr << fmt::format("scene + surfels: {:.1f} s, {} surfels\n", since(t0), surfels.size());
  fs::create_directories(a.sets);
  auto render_set = [&](const fs::path& dir) {
    if (!a.render) return Image{};
    const storage::PageSetReader reader(dir, std::make_shared<storage::PageCache>(uint64_t(8) << 30));
    return render(rays, reader, *cam, a.image);
  };

  // 2. Reference: derived (exact) payloads.
  std::vector<Row> rows;
  rows.push_back(
      build_variant(a, surfels, "derived", tree::PayloadCodecOption::kDerived, 4096, a.sets / "derived", glossy));
  t0 = Clock::now();
  const Image ref_img = render_set(a.sets / "derived");
  std::cerr << fmt::format("reference render: {:.1f} s\n", since(t0));
  uint64_t nodes = 0;
  {
    const storage::PageSetReader reader(a.sets / "derived", nullptr);
    nodes = reader.manifest().stats.node_count;
  }

  // 3. Stored variants.
  auto add_variant = [&](const std::string& name, tree::PayloadCodecOption codec, uint32_t lut, float threshold,
                         storage::LeafFormat leaf_format = storage::LeafFormat::kRelative) {
    const fs::path dir = a.sets / name;
    Row r = build_variant(a, surfels, name, codec, lut, dir, glossy, threshold, leaf_format);
    const Image img = render_set(dir);
    if (a.render) {
      r.psnr_indirect = psnr(ref_img.indirect, img.indirect);
      r.psnr_beauty = psnr(ref_img.beauty, img.beauty);
    }
    rows.push_back(r);
    fs::remove_all(dir);
  };
  add_variant("float32-sh", tree::PayloadCodecOption::kFloatSh, 4096, 0.f);
  for (uint32_t l : a.luts) {
    add_variant(fmt::format("kmeans-sh-l{}", l), tree::PayloadCodecOption::kQuantizedSh, l, 0.f);
  }
  for (float t : a.wavelet_thresholds) {
    add_variant(fmt::format("wavelet-t{}", t), tree::PayloadCodecOption::kDerived, 4096, t);
  }
  for (const std::string& name : a.leaf_formats) {
    const storage::LeafFormat f = storage::parse_leaf_format(name);
    if (f == storage::LeafFormat::kRelative) continue;  // the rows above
    add_variant(fmt::format("float32-sh-{}", name), tree::PayloadCodecOption::kFloatSh, 4096, 0.f, f);
    for (uint32_t l : a.luts) {
      add_variant(fmt::format("kmeans-sh-l{}-{}", l, name), tree::PayloadCodecOption::kQuantizedSh, l, 0.f, f);
    }
  }

  // 4. Report. Ratios are against the float32-sh page set (every node's
  //    payload stored as 144 bytes), the paper's uncompressed tree, of the
  //    same leaf format.
  std::cout << fmt::format("scene {}, {} surfels, leaf_size {}, {} nodes, image {}^2, LUT sample {:.1f} %, "
                           "{} threads\n\n",
                           a.scene.filename().string(), surfels.size(), a.leaf_size, nodes, a.image,
                           100 * a.fraction, tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
  std::cout << "| variant | page set MB | tree ratio | payload MB | payload ratio | payload bits/node | pages | "
               "build s | of which LUT s | LUT entries / sample surfels | load all pages s | PSNR indirect dB | "
               "PSNR beauty dB |\n";
  std::cout << "|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  auto float_row = [&](const Row& r) -> const Row& {
    for (const Row& f : rows) {
      if (f.name.rfind("float32-sh", 0) == 0 && f.leaf_format == r.leaf_format) return f;
    }
    return rows[1];
  };
  for (const Row& r : rows) {
    const Row& fl = float_row(r);
    std::cout << fmt::format(
        "| {} | {:.1f} | {:.2f}x | {:.2f} | {} | {:.2f} | {} | {:.1f} | {:.1f} | {} | {:.2f} | {:.1f} | {:.1f} |\n",
        r.name,
        double(r.file_bytes) / 1e6, double(fl.file_bytes) / double(r.file_bytes), double(r.payload_bytes) / 1e6,
        r.name == "derived" ? std::string("(links only)")
                            : fmt::format("{:.1f}x", double(fl.payload_bytes) / double(r.payload_bytes)),
        8.0 * double(r.payload_bytes) / double(nodes), r.pages, r.build_seconds, r.lut_seconds,
        r.lut_entries ? fmt::format("{} / {}", r.lut_entries, r.lut_sample) : std::string("-"), r.load_seconds,
        r.psnr_indirect,
        r.psnr_beauty);
  }
  std::cout << "\nPSNR against the derived (exact) page set in the relative leaf format; inf = identical "
               "images. Ratios against float32-sh in the row's leaf format.\n";
  if (rows[0].glossy_surfels > 0) {
    std::cout << fmt::format("\nGlossy senders: {} surfels, cube maps {}^2 per face. Stored glossy radiance "
                             "against dense float32 cube maps for every coded node:\n\n",
                             rows[0].glossy_surfels, a.glossy_resolution);
    std::cout << "| variant | glossy MB | dense MB | glossy ratio | lobes s | PSNR indirect dB | PSNR beauty dB |\n";
    std::cout << "|---|---|---|---|---|---|---|\n";
    for (const Row& r : rows) {
      if (r.name != "derived" && r.name.rfind("wavelet", 0) != 0) continue;
      std::cout << fmt::format("| {} | {:.2f} | {:.2f} | {:.1f}x | {:.1f} | {:.1f} | {:.1f} |\n", r.name,
                               double(r.glossy_bytes) / 1e6, double(r.glossy_dense_bytes) / 1e6,
                               double(r.glossy_dense_bytes) / std::max(1.0, double(r.glossy_bytes)),
                               r.glossy_shade_seconds, r.psnr_indirect, r.psnr_beauty);
    }
    std::cout << "\n(derived: threshold 0, the reference of every PSNR.)\n";
  }
  return 0;
}

}  // namespace
}  // namespace pbgi

int main(int argc, char** argv) {
  pbgi::Args a;
  CLI::App app{"bench_codecs: stored node payloads (float SH, k-means-quantized SH) against derived ones"};
  app.add_option("--scene", a.scene, "USD scene");
  app.add_option("--surfels", a.surfels, "target surfel count");
  app.add_option("--image", a.image, "square image size in pixels");
  app.add_option("--leaf-size", a.leaf_size, "surfels per leaf");
  app.add_option("--fraction", a.fraction, "LUT sample fraction of the surfels");
  app.add_option("--lut", a.luts, "LUT sizes");
  app.add_option("--cache", a.cache, "directory caching shaded surfels");
  app.add_option("--sets", a.sets, "directory for the page sets (variants are deleted after measuring)");
  app.add_option("--camera", a.camera, "camera prim");
  app.add_flag("!--no-render", a.render, "skip the images (sizes and times only)");
  app.add_option("--wavelet-threshold", a.wavelet_thresholds,
                 "glossy senders: wavelet thresholds to measure (a variant each)");
  app.add_option("--glossy-resolution", a.glossy_resolution, "glossy senders: cube map pixels per face side");
  app.add_option("--leaf-format", a.leaf_formats,
                 "leaf formats besides relative (format B) to measure: half (format A); each repeats "
                 "float32-sh and every --lut");
  app.add_option("--threads", a.threads, "worker threads (0: all cores; 1: the paper's single-threaded build)");
  CLI11_PARSE(app, argc, argv);
  std::optional<tbb::global_control> threads;
  if (a.threads > 0) threads.emplace(tbb::global_control::max_allowed_parallelism, a.threads);
  try {
    return pbgi::run(a);
  } catch (const std::exception& e) {
    std::cerr << "bench_codecs: " << e.what() << "\n";
    return 1;
  }
}
