// bench_codecs: what the compressed node payloads cost and save on a real
// scene (issue 5, "measure against the paper").
//
//   bench_codecs --scene scenes/cornell.usda --surfels 5000000 --image 256
//
// 1. Surfels: the scene sampled at --surfels and shaded with direct light
//    (cached in --cache so repeated runs skip it).
// 2. Reference: the float32-sh tree, rendered through PBGI (indirect AOV).
// 3. Each variant: LUT learned on a --fraction sample tree, every node
//    quantized, payloads decoded as a reader would, the image rendered again.
// 4. The table: payload and tree bytes, ratios, LUT and quantization times,
//    PSNR of the indirect and beauty images against the reference.
#include "server/ingest/usd_ingest.h"
#include "server/render/tile_renderer.h"
#include "server/scene/ray_scene.h"
#include "server/surfels/surfels.h"
#include "storage/codecs/bit_packing.h"
#include "storage/codecs/float_sh_codec.h"
#include "storage/codecs/quantized_sh_codec.h"
#include "storage/format/errors.h"
#include "storage/tree/memory_tree.h"
#include "storage/tree/tree_builder.h"

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>

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
  uint32_t scale_bits = 12;
  fs::path cache = "/tmp/pbgi_bench_codecs";
  std::string camera = "/Camera";
  bool render = true;
};

// 1. Surfels of the scene, from the cache when present.
std::vector<Surfel> scene_surfels(const Args& a, const Scene& scene, const RayScene& rays) {
  const fs::path file = a.cache / fmt::format("surfels_{}_{}.bin", a.scene.stem().string(), a.surfels);
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
  double payload_bytes = 0;
  double lut_seconds = 0, quantize_seconds = 0;
  uint64_t raw_nodes = 0;
  double psnr_indirect = INFINITY, psnr_beauty = INFINITY;
};

int run(const Args& a) {
  // 1. Scene and surfels.
  auto t0 = Clock::now();
  const Scene scene = read_usd_scene(a.scene, {});
  const RayScene rays(scene);
  const Camera* cam = scene.find_camera(a.camera);
  if (!cam) throw NotFound("camera " + a.camera);
  std::vector<Surfel> surfels = scene_surfels(a, scene, rays);
  std::cerr << fmt::format("scene + surfels: {:.1f} s, {} surfels\n", since(t0), surfels.size());

  // 2. Reference tree and image.
  tree::BuildOptions bo;
  bo.leaf_size = a.leaf_size;
  t0 = Clock::now();
  tree::BuiltTree ref = tree::build_tree(surfels, bo);
  const double build_seconds = since(t0);
  const size_t nodes = ref.nodes.size();
  std::cerr << fmt::format("tree: {} nodes in {:.2f} s\n", nodes, build_seconds);
  const std::vector<tree::Node> ref_nodes = ref.nodes;
  t0 = Clock::now();
  const Image ref_img = [&] {
    if (!a.render) return Image{};
    tree::BuiltTree copy = ref;
    const tree::MemoryTree mt(std::move(copy));
    return render(rays, mt, *cam, a.image);
  }();
  std::cerr << fmt::format("reference render: {:.1f} s\n", since(t0));

  // Whole-tree bytes if every node's payload is stored (the paper's model):
  // per node a shape byte, per leaf an 18-byte frame (V2 page records), per
  // surfel a leaf record in format A (half floats, float32 position: 12 +
  // radius 2 + normal 6 + radiance, albedo, emission 3 x 6 = 38 B) or B
  // (V2's frame-relative 16-bit position and radius, octahedral normal,
  // RGB9E5 colours: 24 B).
  constexpr double kLeafA = 38, kLeafB = 24, kShape = 1, kLeafFrame = 18;
  const double structure = double(nodes) * kShape + double(ref.leaf_count) * kLeafFrame;
  const double surfels_a = double(surfels.size()) * kLeafA, surfels_b = double(surfels.size()) * kLeafB;
  std::vector<Row> rows;
  Row sh{"float32-sh"};
  sh.payload_bytes = double(nodes) * storage::FloatShCodec::kBytesPerNode;
  rows.push_back(sh);

  // 3. Quantized variants.
  for (uint32_t l : a.luts) {
    Row r{fmt::format("kmeans-sh l={}", l)};
    storage::ShLutOptions lo;
    lo.entries = l;
    lo.scale_bits = a.scale_bits;
    lo.sample_fraction = a.fraction;
    t0 = Clock::now();
    const std::vector<Surfel> sample = storage::sample_surfels(surfels, lo);
    const tree::BuiltTree sample_tree = tree::build_tree(sample, bo);
    const storage::ShLutTraining training = storage::train_sh_lut(sample_tree.nodes, lo);
    r.lut_seconds = since(t0);
    const auto codec = std::make_shared<const storage::QuantizedShCodec>(
        std::make_shared<const storage::QuantizedShTable>(training.table));
    std::cerr << fmt::format("  l={}: {} entries from {} sample nodes, k-means {} iterations ({:.2f} s seeding, "
                             "{:.2f} s Lloyd), objective {:.4g} -> {:.4g}, LUT {:.2f} s\n",
                             l, training.table.size(), training.sample_nodes, training.kmeans.iterations,
                             training.kmeans.seeding_seconds, training.kmeans.lloyd_seconds,
                             training.kmeans.objective.front(), training.kmeans.objective.back(), r.lut_seconds);
    // Quantize every node, then decode as a reader does (raw nodes verbatim).
    tree::BuiltTree q = ref;
    std::atomic<uint64_t> raw{0};
    t0 = Clock::now();
    tbb::parallel_for(tbb::blocked_range<size_t>(0, nodes, 4096), [&](const auto& range) {
      uint64_t local = 0;
      uint32_t hint = storage::NearestCentreTable::kNoHint;  // pre-order: often the parent's entry
      for (size_t i = range.begin(); i < range.end(); ++i) {
        const storage::QuantizedPayload code = codec->quantize(q.nodes[i], hint);
        if (code.raw) {
          ++local;
        } else {
          hint = code.index;
          codec->dequantize(code, q.nodes[i]);
        }
      }
      raw += local;
    });
    r.quantize_seconds = since(t0);
    r.raw_nodes = raw;
    const double lut_bytes = double(training.table.serialize().size());
    r.payload_bytes = double(storage::packed_bytes(nodes, codec->code_bits())) + double(r.raw_nodes) * 144 + lut_bytes;
    if (a.render) {
      const tree::MemoryTree mt(std::move(q));
      const Image img = render(rays, mt, *cam, a.image);
      r.psnr_indirect = psnr(ref_img.indirect, img.indirect);
      r.psnr_beauty = psnr(ref_img.beauty, img.beauty);
    }
    std::cerr << fmt::format("  quantized {} nodes in {:.2f} s ({} raw), PSNR {:.1f} dB\n", nodes, r.quantize_seconds,
                             r.raw_nodes, r.psnr_indirect);
    rows.push_back(r);
  }

  // 4. Report.
  std::cout << fmt::format("scene {}, {} surfels, leaf_size {}, {} nodes, tree build {:.2f} s, image {}^2, "
                           "LUT sample {:.1f} %, scale bits {}\n\n",
                           a.scene.filename().string(), surfels.size(), a.leaf_size, nodes, build_seconds, a.image,
                           100 * a.fraction, a.scale_bits);
  std::cout << "| variant | payload MB | payload ratio | bits/node | tree A MB | ratio A | tree B MB | ratio B | "
               "raw nodes | LUT s | quantize s | PSNR indirect dB | PSNR beauty dB |\n";
  std::cout << "|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  const double ref_a = structure + rows[0].payload_bytes + surfels_a;
  for (const Row& r : rows) {
    const double tree_a = structure + r.payload_bytes + surfels_a, tree_b = structure + r.payload_bytes + surfels_b;
    std::cout << fmt::format(
        "| {} | {:.2f} | {:.1f}x | {:.2f} | {:.1f} | {:.2f}x | {:.1f} | {:.2f}x | {} | {:.2f} | {:.2f} | {:.1f} | {:.1f} |\n",
        r.name, r.payload_bytes / 1e6, rows[0].payload_bytes / r.payload_bytes, 8 * r.payload_bytes / double(nodes),
        tree_a / 1e6, ref_a / tree_a, tree_b / 1e6, ref_a / tree_b, r.raw_nodes, r.lut_seconds, r.quantize_seconds,
        r.psnr_indirect, r.psnr_beauty);
  }
  std::cout << fmt::format("\ntree ratios are against float32-sh with leaf format A ({:.1f} MB); structure "
                           "(shapes + leaf frames) {:.1f} MB, {} leaves\n",
                           ref_a / 1e6, structure / 1e6, ref.leaf_count);
  return 0;
}

}  // namespace
}  // namespace pbgi

int main(int argc, char** argv) {
  pbgi::Args a;
  CLI::App app{"bench_codecs: compressed node payloads against float SH"};
  app.add_option("--scene", a.scene, "USD scene");
  app.add_option("--surfels", a.surfels, "target surfel count");
  app.add_option("--image", a.image, "square image size in pixels");
  app.add_option("--leaf-size", a.leaf_size, "surfels per leaf");
  app.add_option("--fraction", a.fraction, "LUT sample fraction of the surfels");
  app.add_option("--lut", a.luts, "LUT sizes");
  app.add_option("--scale-bits", a.scale_bits, "bits of the log scale");
  app.add_option("--cache", a.cache, "directory caching shaded surfels");
  app.add_option("--camera", a.camera, "camera prim");
  app.add_flag("!--no-render", a.render, "skip the images (sizes and times only)");
  CLI11_PARSE(app, argc, argv);
  try {
    return pbgi::run(a);
  } catch (const std::exception& e) {
    std::cerr << "bench_codecs: " << e.what() << "\n";
    return 1;
  }
}
