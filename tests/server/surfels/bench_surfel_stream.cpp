// The streaming pipeline on a USD scene (e.g. scripts/gen_large_scene.py):
// surfels sampled and shaded batch by batch straight into a page-set build
// with a sort-memory budget, as the daemon builds a scene.
//
//   bench_surfel_stream SCENE --surfels N [--sampler uniform|poisson]
//       [--camera /World/Camera --footprint F] [--light-samples N]
//       [--sort-memory SIZE] [--dir DIR] [--keep]
//
// Reports sampling and shading throughput (surfels per second of wall and
// CPU time), the tree build's, bytes per surfel and peak RSS.
#include "server/ingest/usd_ingest.h"
#include "server/surfels/surfels.h"
#include "storage/pages/page_set.h"

#include <sys/resource.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <string>

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }
double cpu_seconds() {  // all threads of the process
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}
double peak_rss_gib() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return double(u.ru_maxrss) / (1024.0 * 1024.0);
}
uint64_t parse_size(const std::string& s) {
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  const std::string u = end;
  const double m = u == "K" || u == "KiB" ? 1024.0 : u == "M" || u == "MiB" ? 1048576.0
                 : u == "G" || u == "GiB" ? 1073741824.0 : 1.0;
  return uint64_t(v * m);
}

}  // namespace

int main(int argc, char** argv) {
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  if (argc < 2) {
    std::fprintf(stderr, "usage: bench_surfel_stream SCENE [--surfels N] [--sampler uniform|poisson] "
                         "[--camera PATH --footprint F] [--light-samples N] [--sort-memory SIZE] [--dir DIR] [--keep]\n");
    return 2;
  }
  const std::filesystem::path scene_path = argv[1];
  pbgi::SurfelOptions so;
  so.target_surfels = 1000000;
  so.light_samples = 4;
  pbgi::tree::BuildOptions to;
  to.sort_memory_bytes = uint64_t(1) << 30;
  std::filesystem::path dir = std::filesystem::temp_directory_path();
  bool keep = false;
  for (int i = 2; i < argc; ++i) {
    const std::string k = argv[i];
    auto val = [&] { return std::string(i + 1 < argc ? argv[++i] : ""); };
    if (k == "--surfels") so.target_surfels = parse_size(val());
    else if (k == "--sampler") so.sampler = val() == "poisson" ? pbgi::SurfelSampler::kPoisson : pbgi::SurfelSampler::kUniform;
    else if (k == "--camera") so.camera = val();
    else if (k == "--footprint") so.pixel_footprint = std::stof(val());
    else if (k == "--light-samples") so.light_samples = uint32_t(parse_size(val()));
    else if (k == "--sort-memory") to.sort_memory_bytes = parse_size(val());
    else if (k == "--dir") dir = val();
    else if (k == "--keep") keep = true;
    else {
      std::fprintf(stderr, "unknown option %s\n", k.c_str());
      return 2;
    }
  }
  try {
    auto t = Clock::now();
    const pbgi::Scene scene = pbgi::read_usd_scene(scene_path, pbgi::IngestOptions{});
    std::printf("read           %.1f s: %zu triangles, %zu lights\n", since(t), scene.triangles.triangle_count(),
                scene.lights.size());
    t = Clock::now();
    const pbgi::RayScene rays(scene);
    std::printf("bvh            %.1f s\n", since(t));
    const double rss_scene = peak_rss_gib();

    const std::filesystem::path set = dir / "bench-surfel-stream";
    std::filesystem::remove_all(set);
    pbgi::storage::PageSetBuilder builder(to, "bench", set, scene.bounds());
    t = Clock::now();
    const double c0 = cpu_seconds();
    const pbgi::SurfelGenerationStats g = pbgi::generate_surfels(
        scene, rays, so, [&](std::span<const pbgi::Surfel> b) { builder.add(b); },
        [](const char* stage, float f) {
          static int last = -1;
          if (int(f * 20) != last) {
            last = int(f * 20);
            std::fprintf(stderr, "\r%s %3d%%", stage, last * 5);
          }
        });
    const double gen_wall = since(t), gen_cpu = cpu_seconds() - c0;
    std::fprintf(stderr, "\n");
    t = Clock::now();
    const double c1 = cpu_seconds();
    const pbgi::storage::Manifest m = builder.finish();
    const double fin_wall = since(t), fin_cpu = cpu_seconds() - c1;
    const auto& r = builder.report();
    const double n = double(g.surfels);
    std::printf("surfels        %llu (%s sampler%s, %u light samples per light)\n", (unsigned long long)g.surfels,
                so.sampler == pbgi::SurfelSampler::kPoisson ? "poisson" : "uniform",
                so.adaptive() ? (", camera " + so.camera).c_str() : "", so.light_samples);
    std::printf("sample         %.1f s wall: %.3g surfels/s\n", g.sample_seconds, n / g.sample_seconds);
    std::printf("shade          %.1f s wall: %.3g surfels/s\n", g.shade_seconds, n / g.shade_seconds);
    std::printf("sample+shade   %.3g surfels/s wall, %.3g surfels per CPU second (2 cores)\n",
                n / (g.sample_seconds + g.shade_seconds), n / (gen_cpu - r.add_seconds));
    std::printf("tree build     %.3g surfels/s wall (sort %.1f s during generation, merge+tree+pages %.1f s, %.1f s CPU)\n",
                n / (r.add_seconds + fin_wall), r.add_seconds, fin_wall, fin_cpu);
    std::printf("sort           %u runs, %u merges, peak buffers %.0f MiB of %.0f\n", r.runs, r.merges,
                double(r.sort_peak_bytes) / 1048576, double(to.sort_memory_bytes) / 1048576);
    std::printf("page set       %.2f GiB, %u pages, %.2f bytes/surfel, depth %u\n", double(m.stats.file_bytes) / (1 << 30),
                m.stats.page_count, double(m.stats.file_bytes) / n, m.stats.max_depth);
    std::printf("peak RSS       %.2f GiB (%.2f GiB after reading the scene and building its BVH)\n", peak_rss_gib(),
                rss_scene);
    if (!keep) std::filesystem::remove_all(set);
    (void)gen_wall;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_surfel_stream: %s\n", e.what());
    return 1;
  }
  return 0;
}
