// Receivers per second of one Gatherer (single thread) on a closed box room
// of ~200k surfels (tests/server/gather/surfel_shapes.h), receivers spread
// over the floor and two walls. Arguments: microbuffer resolution,
// max_solid_angle in thousandths of a steradian.
//  BM_Gather:        the in-memory test tree (surfel_tree.h);
//  BM_GatherPageSet: the production page set (64 KB pages, built in a
//                    temporary directory) read through a page cache that
//                    holds it all, as a warm daemon would.
#include "server/gather/gather.h"
#include "surfel_shapes.h"
#include "surfel_tree.h"

#include <benchmark/benchmark.h>

#include <filesystem>
#include <memory>
#include <random>
#include <vector>

#if PBGI_BENCH_PAGE_SET
#include "storage/cache/page_cache.h"
#include "storage/pages/page_set.h"
#endif

namespace pbgi {
namespace {

constexpr float kRoomSize = 4.f;

const test::SurfelTree& room_tree() {
  static const std::unique_ptr<test::SurfelTree> tree = [] {
    test::SurfelTreeOptions o;
    o.nodes_per_page = 256;  // ~64 KB pages, as the page set lays them out
    return std::make_unique<test::SurfelTree>(test::box_room(kRoomSize, 200000), o);
  }();
  return *tree;
}

// Receivers on the floor and the walls, just off the surface.
std::vector<Receiver> receivers(size_t count) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.02f, kRoomSize - 0.02f);
  std::vector<Receiver> out;
  for (size_t i = 0; i < count; ++i) {
    const float a = u(rng), b = u(rng);
    switch (i % 3) {
      case 0:
        out.push_back({{a, b, 1e-3f}, {0, 0, 1}});
        break;  // floor
      case 1:
        out.push_back({{1e-3f, a, b}, {1, 0, 0}});
        break;  // red wall
      default:
        out.push_back({{a, kRoomSize - 1e-3f, b}, {0, -1, 0}});
        break;  // back wall
    }
  }
  return out;
}

void run(benchmark::State& state, const tree::TreeSource& tree) {
  GatherOptions o;
  o.microbuffer_resolution = uint32_t(state.range(0));
  o.max_solid_angle = float(state.range(1)) * 1e-3f;
  Gatherer g(tree, o);
  const std::vector<Receiver> rs = receivers(4096);
  size_t i = 0;
  float sink = 0.f;
  for (auto _ : state) {
    sink += g.gather(rs[i]).irradiance.x;
    i = (i + 1) % rs.size();
  }
  benchmark::DoNotOptimize(sink);
  state.SetItemsProcessed(int64_t(state.iterations()));
  const GatherCounters& c = g.counters();
  const double n = double(c.receivers);
  state.counters["nodes_visited"] = double(c.nodes_visited) / n;
  state.counters["splats"] = double(c.nodes_rasterized + c.surfels_splatted) / n;
  state.counters["raycasts"] = double(c.surfels_raycast) / n;
  state.counters["pages"] = double(c.pages_fetched) / n;
}

void BM_Gather(benchmark::State& state) { run(state, room_tree()); }
BENCHMARK(BM_Gather)
    ->Args({8, 30})
    ->Args({4, 30})
    ->Args({16, 30})
    ->Args({8, 10})
    ->Args({16, 10})
    ->Unit(benchmark::kMicrosecond);

#if PBGI_BENCH_PAGE_SET
// The page set is built once into a temporary directory removed at exit.
class RoomPageSet {
 public:
  RoomPageSet() {
    dir_ = std::filesystem::temp_directory_path() /
           ("pbgi_bench_gather_" + std::to_string(std::random_device{}()));
    std::filesystem::create_directories(dir_);
    storage::build_page_set(test::box_room(kRoomSize, 200000), tree::BuildOptions{}, "bench",
                            dir_ / "set");
    reader_ = std::make_unique<storage::PageSetReader>(
        dir_ / "set", std::make_shared<storage::PageCache>(uint64_t(1) << 30));
  }
  ~RoomPageSet() {
    reader_.reset();
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }
  const storage::PageSetReader& reader() const { return *reader_; }

 private:
  std::filesystem::path dir_;
  std::unique_ptr<storage::PageSetReader> reader_;
};

void BM_GatherPageSet(benchmark::State& state) {
  static RoomPageSet set;
  run(state, set.reader());
}
BENCHMARK(BM_GatherPageSet)->Args({8, 30})->Args({16, 30})->Unit(benchmark::kMicrosecond);
#endif

}  // namespace
}  // namespace pbgi

BENCHMARK_MAIN();
