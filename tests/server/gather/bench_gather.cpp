// bench_gather: speed and error of the gather on a Cornell-like room.
//
// Scene: the closed box room of tests/server/gather/surfel_shapes.h (4 m,
// ~200k surfels: red and green side walls, white floor, ceiling and back
// walls, an emissive ceiling patch, two blocks), as an in-memory tree
// (surfel_tree.h, 64 KB pages) or, with --page-set, as the production page
// set read through a warm page cache.
//
// Receivers: what a renderer would gather. A pinhole camera inside the room
// renders a --width x --width image; --tiles image tiles of --tile x --tile
// pixels (spread over the image by a fixed seed) give one receiver per pixel
// on the first surface hit, 1 mm off it. Each tile is one gather_tile call.
//
// Error: against a fine reference gather (--ref-res, --ref-angle) of every
// --ref-stride-th receiver in each direction, computed once with all cores
// and cached in the build directory. Reported per configuration:
//   rel_rmse  = sqrt(mean |E - E_ref|^2) / mean |E_ref|  (RGB norms)
//   mean_rel  = mean |E - E_ref| / mean |E_ref|
//   ao_rmse   = RMS AO difference
//   vs_pbgi   = rel_rmse against plain PBGI at the same resolution and angle
// Speed: receivers per second of CPU time of the one benchmark thread
// (best of --repeat passes over all tiles).
//
// Usage:
//   bench_gather [--configs LIST] [--width 512] [--tile 32] [--tiles 8]
//                [--surfels 200000] [--repeat 3] [--ref-res 32] [--ref-angle 0.002]
//                [--ref-stride 2] [--no-error] [--page-set] [--glossy ROUGHNESS]
// LIST is comma separated; each entry
// method:N:angle[:k=K][:eps=E][:hdr=H][:gres=N][:gimp=X][:grw=W] (gres,
// gimp, grw: the glossy options glossy_max_resolution, glossy_importance
// and glossy_radiance_weight),
// method pbgi or fpbgi, e.g. "pbgi:8:0.03,fpbgi:8:0.03:k=100:eps=0.01".
// --glossy R makes every receiver glossy (roughness R, F0 1, seen from the
// camera): the reference uses glossy_max_resolution 64 and importance
// 1e-3, errors and vs_pbgi are those of the glossy radiance, nodes count
// the glossy walks too.
// For profiling: valgrind --tool=callgrind --toggle-collect='*gather_tile*'
//   bench_gather --configs pbgi:8:0.03 --tiles 1 --repeat 1 --no-error
#include "server/gather/gather.h"
#include "surfel_shapes.h"
#include "surfel_tree.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <random>
#include <span>
#include <stdexcept>
#include <string>
#include <thread>
#include <time.h>
#include <vector>

#if PBGI_BENCH_PAGE_SET
#include "storage/cache/page_cache.h"
#include "storage/pages/page_set.h"
#endif

namespace pbgi {
namespace {

using Imath::C3f;
using Imath::V3f;

constexpr float kRoomSize = 4.f;

struct Args {
  std::string configs = "pbgi:8:0.03,pbgi:16:0.03";
  uint32_t width = 512, tile = 32, tiles = 8, surfels = 200000, repeat = 3;
  uint32_t ref_res = 32, ref_stride = 2;
  float ref_angle = 0.002f;
  bool error = true, page_set = false;
  // >= 0: every receiver is glossy (this GGX roughness, white F0, viewed
  // from the camera) and the error is that of the glossy radiance.
  float glossy = -1.f;
};

// ---------------------------------------------------------------- scene

struct Box {
  V3f lo, hi;
};

// The two blocks of test::box_room, in units of the room size.
Box block(int i) {
  const float S = kRoomSize;
  if (i == 0) return {V3f(0.2f, 0.2f, 0.f) * S, V3f(0.45f, 0.45f, 0.5f) * S};
  return {V3f(0.6f, 0.55f, 0.f) * S, V3f(0.8f, 0.75f, 0.25f) * S};
}

// Nearest hit of a ray from inside the room with its walls (inward
// normals), the blocks (outward normals) and the emissive patch (facing
// down). Returns false if nothing is hit (cannot happen from inside).
bool trace(const V3f& o, const V3f& d, V3f& hit, V3f& normal) {
  float best = 1e30f;
  for (int a = 0; a < 3; ++a) {  // room walls
    if (d[a] == 0.f) continue;
    const float bound = d[a] > 0.f ? kRoomSize : 0.f;
    const float t = (bound - o[a]) / d[a];
    if (t > 0.f && t < best) {
      best = t;
      normal = V3f(0);
      normal[a] = d[a] > 0.f ? -1.f : 1.f;
    }
  }
  for (int b = 0; b < 2; ++b) {  // blocks: slab test
    const Box box = block(b);
    float t0 = 0.f, t1 = best;
    int axis = -1;
    bool ok = true;
    for (int a = 0; a < 3 && ok; ++a) {
      const float inv = 1.f / d[a];
      float n = (box.lo[a] - o[a]) * inv, f = (box.hi[a] - o[a]) * inv;
      if (n > f) std::swap(n, f);
      if (n > t0) {
        t0 = n;
        axis = a;
      }
      t1 = std::min(t1, f);
      ok = t0 <= t1;
    }
    if (ok && axis >= 0 && t0 < best) {
      best = t0;
      normal = V3f(0);
      normal[axis] = d[axis] > 0.f ? -1.f : 1.f;
    }
  }
  // Emissive patch: a square of side S/4 centered under the ceiling.
  const float S = kRoomSize, z = 0.99f * S, l = 0.25f * S;
  if (d.z > 0.f) {
    const float t = (z - o.z) / d.z;
    const V3f p = o + d * t;
    if (t > 0.f && t < best && std::abs(p.x - 0.5f * S) < 0.5f * l &&
        std::abs(p.y - 0.5f * S) < 0.5f * l) {
      best = t;
      normal = V3f(0, 0, -1);
    }
  }
  if (best >= 1e30f) return false;
  hit = o + d * best;
  return true;
}

// One tile of receivers, row-major.
struct Tile {
  std::vector<Receiver> receivers;
  uint32_t size = 0;
};

std::vector<Tile> make_tiles(const Args& a) {
  const float S = kRoomSize;
  const V3f eye(0.5f * S, 0.03f * S, 0.55f * S);
  const V3f target(0.5f * S, 1.f * S, 0.3f * S);
  const V3f fwd = (target - eye).normalized();
  const V3f right = fwd.cross(V3f(0, 0, 1)).normalized();
  const V3f up = right.cross(fwd);
  const float tan_half = std::tan(0.5f * 75.f * 3.14159265f / 180.f);
  const uint32_t grid = a.width / a.tile;
  std::mt19937 rng(3);
  std::vector<uint32_t> ids(grid * grid);
  for (uint32_t i = 0; i < ids.size(); ++i) ids[i] = i;
  std::shuffle(ids.begin(), ids.end(), rng);
  std::vector<Tile> tiles;
  for (uint32_t t = 0; t < std::min<uint32_t>(a.tiles, uint32_t(ids.size())); ++t) {
    const uint32_t tx = ids[t] % grid, ty = ids[t] / grid;
    Tile tile;
    tile.size = a.tile;
    for (uint32_t y = ty * a.tile; y < (ty + 1) * a.tile; ++y) {
      for (uint32_t x = tx * a.tile; x < (tx + 1) * a.tile; ++x) {
        const float sx = (2.f * (float(x) + 0.5f) / float(a.width) - 1.f) * tan_half;
        const float sy = (1.f - 2.f * (float(y) + 0.5f) / float(a.width)) * tan_half;
        const V3f d = (fwd + right * sx + up * sy).normalized();
        V3f p, n;
        if (!trace(eye, d, p, n)) throw std::runtime_error("camera ray escaped the room");
        tile.receivers.push_back({p + n * 1e-3f, n});
        if (a.glossy >= 0.f) {
          GlossyLobe& g = tile.receivers.back().glossy;
          g.view = -d;
          g.roughness = a.glossy;
          g.specular = C3f(1.f);
        }
      }
    }
    tiles.push_back(std::move(tile));
  }
  return tiles;
}

// ---------------------------------------------------------------- configs

struct Config {
  std::string text;
  GatherOptions options;
};

std::vector<Config> parse_configs(const std::string& list) {
  std::vector<Config> out;
  size_t start = 0;
  while (start < list.size()) {
    size_t end = list.find(',', start);
    if (end == std::string::npos) end = list.size();
    const std::string item = list.substr(start, end - start);
    start = end + 1;
    std::vector<std::string> parts;
    size_t s = 0;
    while (s <= item.size()) {
      size_t e = item.find(':', s);
      if (e == std::string::npos) e = item.size();
      parts.push_back(item.substr(s, e - s));
      s = e + 1;
    }
    if (parts.size() < 3) throw std::runtime_error("bad config '" + item + "'");
    Config c;
    c.text = item;
    if (parts[0] == "pbgi") {
      c.options.method = GatherMethod::kPbgi;
    } else if (parts[0] == "fpbgi") {
      c.options.method = GatherMethod::kFpbgi;
    } else {
      throw std::runtime_error("unknown method in '" + item + "'");
    }
    c.options.microbuffer_resolution = uint32_t(std::stoul(parts[1]));
    c.options.max_solid_angle = std::stof(parts[2]);
    for (size_t i = 3; i < parts.size(); ++i) {
      const std::string& p = parts[i];
      if (p.rfind("k=", 0) == 0) c.options.clusters = uint32_t(std::stoul(p.substr(2)));
      else if (p.rfind("eps=", 0) == 0) c.options.epsilon = std::stof(p.substr(4));
      else if (p.rfind("hdr=", 0) == 0) c.options.hdr_refine = std::stof(p.substr(4));
      else if (p.rfind("gres=", 0) == 0) c.options.glossy_max_resolution = uint32_t(std::stoul(p.substr(5)));
      else if (p.rfind("gimp=", 0) == 0) c.options.glossy_importance = std::stof(p.substr(5));
      else if (p.rfind("grw=", 0) == 0) c.options.glossy_radiance_weight = std::stof(p.substr(4));
      else throw std::runtime_error("unknown parameter '" + p + "' in '" + item + "'");
    }
    c.options.validate();
    out.push_back(c);
  }
  return out;
}

// ---------------------------------------------------------------- reference

// Receivers whose error is measured: every stride-th in x and y of each tile.
std::vector<size_t> sampled(const Tile& t, uint32_t stride) {
  std::vector<size_t> out;
  for (uint32_t y = 0; y < t.size; y += stride)
    for (uint32_t x = 0; x < t.size; x += stride) out.push_back(size_t(y) * t.size + x);
  return out;
}

uint64_t fnv(const void* data, size_t n, uint64_t h = 1469598103934665603ull) {
  const unsigned char* p = static_cast<const unsigned char*>(data);
  for (size_t i = 0; i < n; ++i) h = (h ^ p[i]) * 1099511628211ull;
  return h;
}

// Fine reference gather of the sampled receivers of all tiles, in order;
// cached in the build directory under a hash of receivers and settings.
std::vector<GatherResult> reference(const tree::TreeSource& tree, const std::vector<Tile>& tiles,
                                    const Args& a, const std::string& scene_key) {
  std::vector<Receiver> rs;
  for (const Tile& t : tiles)
    for (size_t i : sampled(t, a.ref_stride)) rs.push_back(t.receivers[i]);
  uint64_t h = fnv(rs.data(), rs.size() * sizeof(Receiver));
  h = fnv(scene_key.data(), scene_key.size(), h);
  h = fnv(&a.ref_res, sizeof a.ref_res, h);
  h = fnv(&a.ref_angle, sizeof a.ref_angle, h);
  const std::filesystem::path file = std::filesystem::path(PBGI_TEST_BINARY_DIR) / "bench" /
                                     ("gather_reference_" + std::to_string(h) + ".bin");
  std::vector<GatherResult> out(rs.size());
  {
    std::ifstream in(file, std::ios::binary);
    if (in.read(reinterpret_cast<char*>(out.data()), std::streamsize(out.size() * sizeof(GatherResult))))
      return out;
  }
  std::fprintf(stderr, "computing the reference (%zu receivers, N = %u, %.4g sr)...\n", rs.size(),
               a.ref_res, a.ref_angle);
  GatherOptions o;
  o.microbuffer_resolution = a.ref_res;
  o.max_solid_angle = a.ref_angle;
  // Glossy receivers: the finest lobe buffer, splitting cells down to 0.1%
  // of the lobe.
  o.glossy_max_resolution = GatherOptions::kMaxGlossyResolution;
  o.glossy_importance = 1e-3f;
  const unsigned threads = std::max(1u, std::thread::hardware_concurrency());
  std::vector<std::thread> pool;
  for (unsigned t = 0; t < threads; ++t) {
    pool.emplace_back([&, t] {
      Gatherer g(tree, o);
      for (size_t i = t; i < rs.size(); i += threads) out[i] = g.gather(rs[i]);
    });
  }
  for (auto& th : pool) th.join();
  std::filesystem::create_directories(file.parent_path());
  std::ofstream(file, std::ios::binary)
      .write(reinterpret_cast<const char*>(out.data()), std::streamsize(out.size() * sizeof(GatherResult)));
  return out;
}

// ---------------------------------------------------------------- measure

double thread_seconds() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

struct Errors {
  double rel_rmse = 0, mean_rel = 0, ao_rmse = 0;
};

// Irradiance errors, or with `glossy` those of the glossy radiance.
Errors compare(const std::vector<GatherResult>& got, const std::vector<GatherResult>& ref,
               bool glossy = false) {
  double se = 0, ae = 0, norm = 0, ao = 0;
  for (size_t i = 0; i < got.size(); ++i) {
    const C3f d = glossy ? got[i].glossy - ref[i].glossy : got[i].irradiance - ref[i].irradiance;
    const double e2 = double(d.x) * d.x + double(d.y) * d.y + double(d.z) * d.z;
    se += e2;
    ae += std::sqrt(e2);
    norm += glossy ? ref[i].glossy.length() : ref[i].irradiance.length();
    const double da = got[i].ao - ref[i].ao;
    ao += da * da;
  }
  const double n = double(std::max<size_t>(1, got.size()));
  Errors e;
  e.rel_rmse = std::sqrt(se / n) / (norm / n);
  e.mean_rel = ae / norm;
  e.ao_rmse = std::sqrt(ao / n);
  return e;
}

void usage() {
  std::fprintf(stderr,
               "bench_gather [--configs LIST] [--width W] [--tile T] [--tiles N] [--surfels S]\n"
               "             [--repeat R] [--ref-res N] [--ref-angle SR] [--ref-stride S]\n"
               "             [--no-error] [--page-set] [--glossy ROUGHNESS]\n");
}

Args parse_args(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string k = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) throw std::runtime_error("missing value after " + k);
      return argv[++i];
    };
    if (k == "--configs") a.configs = next();
    else if (k == "--width") a.width = uint32_t(std::stoul(next()));
    else if (k == "--tile") a.tile = uint32_t(std::stoul(next()));
    else if (k == "--tiles") a.tiles = uint32_t(std::stoul(next()));
    else if (k == "--surfels") a.surfels = uint32_t(std::stoul(next()));
    else if (k == "--repeat") a.repeat = uint32_t(std::stoul(next()));
    else if (k == "--ref-res") a.ref_res = uint32_t(std::stoul(next()));
    else if (k == "--ref-angle") a.ref_angle = std::stof(next());
    else if (k == "--ref-stride") a.ref_stride = uint32_t(std::stoul(next()));
    else if (k == "--no-error") a.error = false;
    else if (k == "--page-set") a.page_set = true;
    else if (k == "--glossy") a.glossy = std::stof(next());
    else {
      usage();
      throw std::runtime_error("unknown argument " + k);
    }
  }
  if (a.tile == 0 || a.width < a.tile || a.ref_stride == 0)
    throw std::runtime_error("bad --width/--tile/--ref-stride");
  return a;
}

#if PBGI_BENCH_PAGE_SET
// The production page set, built into a temporary directory removed at exit.
class RoomPageSet {
 public:
  explicit RoomPageSet(uint32_t surfels) {
    dir_ = std::filesystem::temp_directory_path() /
           ("pbgi_bench_gather_" + std::to_string(std::random_device{}()));
    std::filesystem::create_directories(dir_);
    storage::build_page_set(test::box_room(kRoomSize, surfels), tree::BuildOptions{}, "bench",
                            dir_ / "set");
    reader_ = std::make_unique<storage::PageSetReader>(
        dir_ / "set", std::make_shared<storage::PageCache>(uint64_t(1) << 30));
  }
  ~RoomPageSet() {
    reader_.reset();
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }
  const tree::TreeSource& source() const { return *reader_; }

 private:
  std::filesystem::path dir_;
  std::unique_ptr<storage::PageSetReader> reader_;
};
#endif

int run(int argc, char** argv) {
  const Args a = parse_args(argc, argv);
  const std::vector<Config> configs = parse_configs(a.configs);

  // 1. Scene and tree.
  std::unique_ptr<tree::TreeSource> owned;
#if PBGI_BENCH_PAGE_SET
  std::unique_ptr<RoomPageSet> set;
#endif
  const tree::TreeSource* tree = nullptr;
  std::string scene_key = "room" + std::to_string(a.surfels);
  if (a.page_set) {
#if PBGI_BENCH_PAGE_SET
    set = std::make_unique<RoomPageSet>(a.surfels);
    tree = &set->source();
    scene_key += "-pageset";
#else
    throw std::runtime_error("--page-set: built without the page-set library");
#endif
  } else {
    test::SurfelTreeOptions o;
    o.nodes_per_page = 256;  // ~64 KB pages, as the page set lays them out
    owned = std::make_unique<test::SurfelTree>(test::box_room(kRoomSize, a.surfels), o);
    tree = owned.get();
  }

  // 2. Receivers and the reference.
  const std::vector<Tile> tiles = make_tiles(a);
  size_t receiver_count = 0;
  for (const Tile& t : tiles) receiver_count += t.receivers.size();
  std::vector<GatherResult> ref;
  if (a.error) ref = reference(*tree, tiles, a, scene_key);

  std::printf("scene: box room %.0f m, %u surfels (%s); %zu tiles of %ux%u from a %ux%u image, "
              "%zu receivers; reference N = %u, %.4g sr on every %u-th receiver\n",
              kRoomSize, a.surfels, a.page_set ? "page set" : "in-memory tree", tiles.size(),
              a.tile, a.tile, a.width, a.width, receiver_count, a.ref_res, a.ref_angle,
              a.ref_stride);
  std::printf("%-34s %10s %9s %8s %7s %8s %8s %8s %8s %8s\n", "config", "recv/s/thr", "us/recv",
              "nodes", "splats", "rays", "rel_rmse", "mean_rel", "ao_rmse", "vs_pbgi");

  // PBGI results per (resolution, angle), to compare FPBGI against.
  std::vector<std::pair<std::string, std::vector<GatherResult>>> pbgi_results;
  for (const Config& c : configs) {
    Gatherer g(*tree, c.options);
    std::vector<std::vector<GatherResult>> results(tiles.size());
    double best = 1e30;
    for (uint32_t pass = 0; pass < std::max(1u, a.repeat); ++pass) {
      const double t0 = thread_seconds();
      for (size_t t = 0; t < tiles.size(); ++t) {
        results[t].resize(tiles[t].receivers.size());
        g.gather_tile(tiles[t].receivers, results[t]);
      }
      best = std::min(best, thread_seconds() - t0);
    }
    const GatherCounters& k = g.counters();
    const double n = double(k.receivers);
    std::vector<GatherResult> got, all;
    std::vector<std::string> where;
    for (size_t t = 0; t < tiles.size(); ++t) {
      for (size_t i : sampled(tiles[t], a.ref_stride)) {
        got.push_back(results[t][i]);
        const Receiver& r = tiles[t].receivers[i];
        char buf[128];
        std::snprintf(buf, sizeof buf, "(%.3f %.3f %.3f) n (%.0f %.0f %.0f)", r.position.x,
                      r.position.y, r.position.z, r.normal.x, r.normal.y, r.normal.z);
        where.push_back(buf);
      }
      all.insert(all.end(), results[t].begin(), results[t].end());
    }
    if (std::getenv("PBGI_BENCH_DUMP")) {
      size_t shown = 0;
      for (size_t i = 0; i < got.size() && shown < 30; ++i)
        if (!ref.empty() && std::abs(got[i].ao - ref[i].ao) > 0.1f && ++shown)
          std::printf("  %zu: p %s E %.4f AO %.4f  ref E %.4f AO %.4f\n", i, where[i].c_str(), got[i].irradiance.x, got[i].ao,
                    ref.empty() ? 0.f : ref[i].irradiance.x, ref.empty() ? 0.f : ref[i].ao);
    }
    char err[128] = "";
    if (a.error) {
      const Errors e = compare(got, ref, a.glossy >= 0.f);
      std::snprintf(err, sizeof err, "%8.4f %8.4f %8.4f", e.rel_rmse, e.mean_rel, e.ao_rmse);
    }
    const std::string key = std::to_string(c.options.microbuffer_resolution) + ":" +
                            std::to_string(c.options.max_solid_angle);
    char vs[32] = "       -";
    if (c.options.method == GatherMethod::kPbgi) {
      pbgi_results.emplace_back(key, all);
    } else {
      for (const auto& [k2, r] : pbgi_results) {
        if (k2 == key) {
          std::snprintf(vs, sizeof vs, "%8.4f", compare(all, r, a.glossy >= 0.f).rel_rmse);
        }
      }
    }
    std::printf("%-34s %10.0f %9.1f %8.0f %7.0f %8.2f %s %s\n", c.text.c_str(),
                double(receiver_count) / best, 1e6 * best / double(receiver_count),
                double(k.nodes_visited + k.glossy_nodes_visited) / n,
                double(k.nodes_rasterized + k.surfels_splatted) / n,
                double(k.surfels_raycast) / n, err, vs);
    std::fflush(stdout);
  }
  return 0;
}

}  // namespace
}  // namespace pbgi

int main(int argc, char** argv) {
  try {
    return pbgi::run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_gather: %s\n", e.what());
    return 1;
  }
}
