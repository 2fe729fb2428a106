// Times surfel sampling and direct shading on a USD scene:
//   bench_surfels [scene.usda] [target_surfels] [light_samples]
// Defaults: scenes/cornell.usda, 200000 surfels, 16 light samples.
#include "server/ingest/usd_ingest.h"
#include "server/surfels/surfels.h"

#include <chrono>
#include <ctime>
#include <cstdio>
#include <cstdlib>
#include <string>

int main(int argc, char** argv) {
  using Clock = std::chrono::steady_clock;
  auto seconds = [](Clock::time_point a, Clock::time_point b) {
    return std::chrono::duration<double>(b - a).count();
  };
  const std::string path = argc > 1 ? argv[1] : PBGI_TEST_SOURCE_DIR "/scenes/cornell.usda";
  pbgi::SurfelOptions options;
  if (argc > 2) options.target_surfels = std::strtoull(argv[2], nullptr, 10);
  if (argc > 3) options.light_samples = static_cast<uint32_t>(std::strtoul(argv[3], nullptr, 10));
  try {
    const auto t0 = Clock::now();
    const pbgi::Scene scene = pbgi::read_usd_scene(path, pbgi::IngestOptions{});
    const auto t1 = Clock::now();
    const pbgi::RayScene rays(scene);
    const auto t2 = Clock::now();
    // CPU time too: on a shared machine wall time says little.
    const std::clock_t c2 = std::clock();
    auto surfels = pbgi::sample_surfels(scene, options);
    const auto t3 = Clock::now();
    const std::clock_t c3 = std::clock();
    pbgi::shade_direct(rays, options, surfels);
    const auto t4 = Clock::now();
    const std::clock_t c4 = std::clock();
    auto cpu = [](std::clock_t a, std::clock_t b) { return double(b - a) / CLOCKS_PER_SEC; };
    double mean = 0;
    for (const auto& s : surfels) mean += (s.radiance.x + s.radiance.y + s.radiance.z) / 3.0;
    std::printf("scene %s: %zu triangles, %zu lights\n", path.c_str(),
                scene.triangles.triangle_count(), scene.lights.size());
    std::printf("read      %8.3f s\n", seconds(t0, t1));
    std::printf("bvh       %8.3f s\n", seconds(t1, t2));
    std::printf("sample    %8.3f s wall %8.3f s cpu  (%zu surfels)\n", seconds(t2, t3),
                cpu(c2, c3), surfels.size());
    std::printf("shade     %8.3f s wall %8.3f s cpu  (%u light samples, %.2f Mrays/cpu-s)\n",
                seconds(t3, t4), cpu(c3, c4), options.light_samples,
                surfels.size() * options.light_samples * scene.lights.size() / cpu(c3, c4) / 1e6);
    std::printf("mean surfel radiance %.4f\n", surfels.empty() ? 0.0 : mean / surfels.size());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_surfels: %s\n", e.what());
    return 1;
  }
  return 0;
}
