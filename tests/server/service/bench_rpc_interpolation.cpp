// bench_rpc_interpolation: what the Gather RPC's interpolation
// (interpolated_gather.h) saves and costs on a real scene.
//
// Receivers: a tile's worth of shading points as a renderer would send
// them: the primary hit of every pixel centre of a --width x --width image
// through the scene's camera (server/render/camera_sample.h; glossy lobes
// kept), in scan order. The scene is opened with the daemon's default
// build options (page set cached in --cache-dir).
// Reported, per tolerance, against a gather of every receiver
// (interpolation off, the reference):
//   gathers/receiver, rel_rmse = sqrt(mean |E - E_ref|^2) / mean |E_ref|
//   (RGB norms of the irradiance), p99 = 99th percentile of
//   |E - E_ref| / |E_ref| per receiver, ao_rmse, and the process CPU
//   time of the gathers (median of --repeat runs, all cores).
//
// Usage:
//   bench_rpc_interpolation --scene scenes/cornell.usda --python .venv/bin/python3
//       [--width 256] [--tolerances 0.05,0.1,0.2] [--repeat 3] [--cache-dir DIR]
#include "server/engine/scene_session.h"
#include "server/render/camera_sample.h"
#include "server/scene/auto_camera.h"
#include "server/scene/camera_rays.h"
#include "server/service/interpolated_gather.h"
#include "storage/cache/page_cache.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <functional>
#include <string>
#include <time.h>
#include <vector>

namespace pbgi {
namespace {

struct Args {
  std::string scene = "scenes/cornell.usda";
  std::string python = "python3";
  std::string cache_dir = "/tmp/pbgi-bench-rpc-interpolation";
  uint32_t width = 256, repeat = 3;
  std::vector<float> tolerances{0.05f, 0.1f, 0.2f};
};

double cpu_seconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

// Median process CPU time of `repeat` runs of `run`; its last result.
service::GatherBatch timed(uint32_t repeat, const std::function<service::GatherBatch()>& run, double* seconds) {
  std::vector<double> times;
  service::GatherBatch out;
  for (uint32_t i = 0; i < repeat; ++i) {
    const double t0 = cpu_seconds();
    out = run();
    times.push_back(cpu_seconds() - t0);
  }
  std::sort(times.begin(), times.end());
  *seconds = times[times.size() / 2];
  return out;
}

float norm(const C3f& c) { return std::sqrt(c.x * c.x + c.y * c.y + c.z * c.z); }

int run(const Args& args) {
  // 1. The scene and a renderer's shading points.
  EngineContext ctx;
  ctx.cache_dir = args.cache_dir;
  ctx.cache = std::make_shared<storage::PageCache>(uint64_t(1) << 30);
  ctx.python = args.python;
  std::filesystem::create_directories(ctx.cache_dir);
  const std::shared_ptr<SceneSession> session = open_scene(args.scene, OpenOptions{}, ctx);
  const Camera camera = resolve_camera(*session->scene, "", 1.f);
  std::vector<Receiver> receivers;
  for (uint32_t y = 0; y < args.width; ++y) {
    for (uint32_t x = 0; x < args.width; ++x) {
      const Ray ray = camera_ray(camera, args.width, args.width, float(x) + 0.5f, float(y) + 0.5f);
      const SurfaceSample s = trace_sample(*session->rays, ray, 0, 0);
      if (s.gathers) receivers.push_back(s.receiver);
    }
  }
  size_t glossy = 0;
  for (const Receiver& r : receivers) glossy += r.glossy.active();
  std::printf("scene %s, %ux%u pixels, %zu receivers (%zu glossy), %llu surfels\n", args.scene.c_str(),
              args.width, args.width, receivers.size(), glossy,
              static_cast<unsigned long long>(session->info.tree.surfel_count));

  // 2. Every receiver gathered: the reference and the time to beat.
  const GatherOptions options;
  double off_seconds = 0;
  const service::GatherBatch full = timed(args.repeat, [&] {
    return service::gather_receivers(*session->tree, receivers, options, {}, session->fog);
  }, &off_seconds);
  std::printf("%-10s %10s %9s %9s %9s %9s %9s %8s\n", "tolerance", "gathers", "per_recv", "rel_rmse", "p99",
              "ao_rmse", "cpu_s", "speedup");
  std::printf("%-10s %10llu %9.4f %9.4f %9.4f %9.4f %9.3f %8.2f\n", "off",
              static_cast<unsigned long long>(full.counters.receivers), 1.0, 0.0, 0.0, 0.0, off_seconds, 1.0);

  // 3. Interpolated, per tolerance.
  for (const float tolerance : args.tolerances) {
    double seconds = 0;
    const service::GatherBatch a = timed(args.repeat, [&] {
      return service::gather_interpolated(*session->tree, receivers, options, tolerance, {}, session->fog);
    }, &seconds);
    double sq = 0, ref = 0, ao_sq = 0;
    std::vector<float> rel;
    for (size_t i = 0; i < receivers.size(); ++i) {
      const float d = norm(a.results[i].irradiance - full.results[i].irradiance);
      const float e = norm(full.results[i].irradiance);
      sq += double(d) * d;
      ref += e;
      rel.push_back(d / std::max(e, 1e-6f));
      const float dao = a.results[i].ao - full.results[i].ao;
      ao_sq += double(dao) * dao;
    }
    const double n = double(receivers.size());
    std::sort(rel.begin(), rel.end());
    std::printf("%-10.3f %10llu %9.4f %9.4f %9.4f %9.4f %9.3f %8.2f\n", tolerance,
                static_cast<unsigned long long>(a.counters.receivers), double(a.counters.receivers) / n,
                std::sqrt(sq / n) / (ref / n), rel[size_t(0.99 * n)], std::sqrt(ao_sq / n), seconds,
                off_seconds / seconds);
  }
  return 0;
}

}  // namespace
}  // namespace pbgi

int main(int argc, char** argv) {
  pbgi::Args args;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const auto value = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "%s needs a value\n", a.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--scene") {
      args.scene = value();
    } else if (a == "--python") {
      args.python = value();
    } else if (a == "--cache-dir") {
      args.cache_dir = value();
    } else if (a == "--width") {
      args.width = uint32_t(std::stoul(value()));
    } else if (a == "--repeat") {
      args.repeat = std::max(1u, uint32_t(std::stoul(value())));
    } else if (a == "--tolerances") {
      args.tolerances.clear();
      const std::string list = value();
      for (size_t p = 0; p < list.size();) {
        const size_t q = std::min(list.find(',', p), list.size());
        args.tolerances.push_back(std::stof(list.substr(p, q - p)));
        p = q + 1;
      }
    } else {
      std::fprintf(stderr, "unknown argument %s (see the comment at the top of the source)\n", a.c_str());
      return 2;
    }
  }
  try {
    return pbgi::run(args);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_rpc_interpolation: %s\n", e.what());
    return 1;
  }
}
