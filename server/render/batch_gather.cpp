#include "server/render/batch_gather.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <mutex>

namespace pbgi {

void gather_receivers(const BatchGatherInput& in, std::span<const Receiver> receivers,
                      std::span<GatherResult> results, GatherCounters& counters) {
  // Blocks of 1024: factorized PBGI's clustering unit (a 32 x 32 tile), and
  // small enough that two cores share a few thousand receivers evenly.
  constexpr size_t kBatch = 1024;
  const bool factorized = in.options.method == GatherMethod::kFpbgi;
  const size_t block = factorized ? kBatch : 64;
  const size_t blocks = (receivers.size() + block - 1) / block;
  std::mutex counters_mutex;
  tbb::parallel_for(tbb::blocked_range<size_t>(0, blocks, 1), [&](const auto& range) {
    Gatherer gatherer(in.tree, in.options, in.cache);
    gatherer.set_volume_points(in.fog);
    gatherer.set_ray_scene(in.rays);
    for (size_t b = range.begin(); b != range.end(); ++b) {
      if (in.check_cancelled) in.check_cancelled();
      const size_t begin = b * block, end = std::min(receivers.size(), begin + block);
      // PBGI too goes through gather_tile: the block's receivers keep the
      // pages they share pinned instead of fetching them each (every
      // receiver touches ~100 pages, each fetch a page cache lookup).
      gatherer.gather_tile(receivers.subspan(begin, end - begin), results.subspan(begin, end - begin));
    }
    std::lock_guard<std::mutex> lock(counters_mutex);
    counters.add(gatherer.counters());
  });
}

}  // namespace pbgi
