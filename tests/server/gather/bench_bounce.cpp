// bench_bounce: CPU time and accuracy of a build-time bounce (surfel_bounce.h)
// with and without view-tree splatting (view_tree_gather.h).
//
// Scene: the closed box room of surfel_shapes.h (4 m, --surfels surfels,
// an emissive ceiling patch, two blocks), every non-emitting surfel of
// albedo (0.7, 0.6, 0.5), in memory. Each configuration runs
// add_bounces(--bounces) on all cores (TBB); reported: process CPU seconds
// and wall seconds of the whole call (tree build included, the same for
// every configuration), and the indirect radiance (final - direct, green)
// against the first configuration: relative RMS and worst difference over
// the reflecting surfels, relative to its mean.
//
// Usage:
//   bench_bounce [--surfels 200000] [--bounces 2] [--configs LIST]
// LIST is comma separated; each entry pbgi | fpbgi | view, then optional
// :omega=SR (the view solid angle), :eps=E (the gather's epsilon),
// :stride=K (sparse receivers), :mb=N and :sa=SR (the bounce gather's
// microbuffer resolution and cut), e.g.
// "pbgi,fpbgi,view,view:omega=0.03" (the default).
#include "server/gather/surfel_bounce.h"
#include "surfel_shapes.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <sstream>
#include <string>
#include <time.h>
#include <vector>

namespace {

using namespace pbgi;

double cpu_seconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

BounceOptions parse(const std::string& entry, uint32_t bounces) {
  BounceOptions o;
  o.bounces = bounces;
  std::stringstream in(entry);
  std::string method;
  std::getline(in, method, ':');
  if (method == "pbgi") {
    o.gather.method = GatherMethod::kPbgi;
    o.splatting = false;
  } else if (method == "fpbgi") {
    o.splatting = false;
  } else if (method == "view") {
    o.splatting = true;
  } else {
    throw std::invalid_argument("unknown method '" + method + "' in '" + entry + "'");
  }
  for (std::string kv; std::getline(in, kv, ':');) {
    if (kv.rfind("omega=", 0) == 0) {
      o.view_solid_angle = std::stof(kv.substr(6));
    } else if (kv.rfind("eps=", 0) == 0) {
      o.gather.epsilon = std::stof(kv.substr(4));
    } else if (kv.rfind("stride=", 0) == 0) {
      o.receiver_stride = uint32_t(std::stoul(kv.substr(7)));
    } else if (kv.rfind("mb=", 0) == 0) {
      o.gather.microbuffer_resolution = uint32_t(std::stoul(kv.substr(3)));
    } else if (kv.rfind("sa=", 0) == 0) {
      o.gather.max_solid_angle = std::stof(kv.substr(3));
    } else {
      throw std::invalid_argument("unknown key '" + kv + "' in '" + entry + "'");
    }
  }
  o.validate();
  return o;
}

}  // namespace

int main(int argc, char** argv) {
  uint32_t surfels = 200000, bounces = 2;
  std::string configs = "pbgi,fpbgi,view,view:omega=0.03";
  for (int i = 1; i < argc; ++i) {
    const auto value = [&]() -> const char* {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "%s needs a value\n", argv[i]);
        std::exit(2);
      }
      return argv[++i];
    };
    if (!std::strcmp(argv[i], "--surfels")) {
      surfels = uint32_t(std::atoi(value()));
    } else if (!std::strcmp(argv[i], "--bounces")) {
      bounces = uint32_t(std::atoi(value()));
    } else if (!std::strcmp(argv[i], "--configs")) {
      configs = value();
    } else {
      std::fprintf(stderr, "unknown argument %s\n", argv[i]);
      return 2;
    }
  }
  try {
    std::vector<Surfel> room = test::box_room(4.f, surfels);
    for (Surfel& x : room) {
      const bool light = x.radiance.x > 5.f;
      x.emission = light ? x.radiance : Imath::C3f(0.f);
      x.albedo = light ? Imath::C3f(0.f) : Imath::C3f(0.7f, 0.6f, 0.5f);
    }
    BounceOptions direct_only;
    const std::vector<Surfel> direct = add_bounces(room, direct_only, tree::BuildOptions{});
    std::printf("box room: %zu surfels, %u bounces\n", room.size(), bounces);
    std::printf("%-24s %10s %10s %10s %10s %12s\n", "config", "cpu_s", "wall_s", "rel_rms", "rel_worst",
                "mean_indir");
    std::vector<Surfel> first;
    std::stringstream list(configs);
    for (std::string entry; std::getline(list, entry, ',');) {
      const BounceOptions o = parse(entry, bounces);
      const double c0 = cpu_seconds();
      const auto w0 = std::chrono::steady_clock::now();
      std::vector<Surfel> out = add_bounces(room, o, tree::BuildOptions{});
      const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - w0).count();
      const double cpu = cpu_seconds() - c0;
      if (first.empty()) first = out;
      double sum = 0, sum2 = 0, worst = 0;
      size_t n = 0;
      for (size_t i = 0; i < out.size(); ++i) {
        if (!(out[i].albedo.y > 0.f)) continue;
        const double d = double(out[i].radiance.y) - double(first[i].radiance.y);
        sum += first[i].radiance.y - direct[i].radiance.y;
        sum2 += d * d;
        worst = std::max(worst, std::abs(d));
        ++n;
      }
      const double mean = sum / double(std::max<size_t>(n, 1));
      std::printf("%-24s %10.2f %10.2f %10.4f %10.4f %12.4f\n", entry.c_str(), cpu, wall,
                  std::sqrt(sum2 / double(std::max<size_t>(n, 1))) / mean, worst / mean, mean);
      std::fflush(stdout);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_bounce: %s\n", e.what());
    return 1;
  }
  return 0;
}
