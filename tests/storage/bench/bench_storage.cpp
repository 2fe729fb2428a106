// Build and read throughput of the storage layer on random surfels.
//   bench_storage --benchmark_filter=Build   (surfels/s, bytes/surfel)
#include "storage/cache/page_cache.h"
#include "storage/pages/page_set.h"
#include "storage/pages/page_set_inspection.h"
#include "storage/tree/tree_builder.h"
#include "tests/storage/pages/temp_dir.h"
#include "tests/storage/tree/random_surfels.h"

#include <benchmark/benchmark.h>

namespace pbgi {
namespace {

void BM_BuildTree(benchmark::State& state) {
  const auto surfels = test::random_surfels(size_t(state.range(0)), 1);
  for (auto _ : state) {
    state.PauseTiming();
    std::vector<Surfel> copy = surfels;
    state.ResumeTiming();
    benchmark::DoNotOptimize(tree::build_tree(std::move(copy), {}));
  }
  state.counters["surfels/s"] =
      benchmark::Counter(double(state.range(0)) * state.iterations(), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_BuildTree)->Arg(1 << 16)->Arg(1000000)->Unit(benchmark::kMillisecond)->UseRealTime();

// The whole build_page_set: tree, packing, encoding, writing, fsync, publish.
void BM_BuildPageSet(benchmark::State& state) {
  const auto surfels = test::random_surfels(size_t(state.range(0)), 1);
  test::TempDir tmp;
  int run = 0;
  storage::Manifest m;
  for (auto _ : state) {
    state.PauseTiming();
    std::vector<Surfel> copy = surfels;
    const auto dir = tmp.path() / std::to_string(run++);
    state.ResumeTiming();
    m = storage::build_page_set(std::move(copy), {}, "bench", dir);
    state.PauseTiming();
    std::filesystem::remove_all(dir);
    state.ResumeTiming();
  }
  state.counters["surfels/s"] =
      benchmark::Counter(double(state.range(0)) * state.iterations(), benchmark::Counter::kIsRate);
  state.counters["bytes/surfel"] = double(m.stats.file_bytes) / double(m.stats.surfel_count);
  state.counters["pages"] = m.stats.page_count;
}
BENCHMARK(BM_BuildPageSet)->Arg(1 << 16)->Arg(1000000)->Unit(benchmark::kMillisecond)->UseRealTime();

// A full walk reading and verifying every page (cold cache each time).
void BM_WalkPageSet(benchmark::State& state) {
  test::TempDir tmp;
  storage::build_page_set(test::random_surfels(size_t(state.range(0)), 1), {}, "bench", tmp.path() / "s");
  uint64_t bytes = 0;
  for (auto _ : state) {
    storage::PageSetReader reader(tmp.path() / "s", std::make_shared<storage::PageCache>(uint64_t(1) << 30));
    const auto r = storage::inspect_page_set(reader);
    bytes += reader.manifest().stats.file_bytes;
    benchmark::DoNotOptimize(r.nodes);
  }
  state.SetBytesProcessed(int64_t(bytes));
}
BENCHMARK(BM_WalkPageSet)->Arg(1000000)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace pbgi

BENCHMARK_MAIN();
