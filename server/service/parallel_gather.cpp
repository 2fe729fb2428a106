#include "server/service/parallel_gather.h"

#include "common/errors.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>
#include <tbb/task_group.h>

#include <atomic>
#include <chrono>
#include <memory>

namespace pbgi::service {

GatherPool::GatherPool(const tree::TreeSource& tree, const GatherOptions& options, std::function<bool()> cancelled,
                       std::shared_ptr<const VolumePoints> fog, const RayScene* rays)
    : tree_(tree), options_(options), cancelled_(std::move(cancelled)), fog_(std::move(fog)), rays_(rays) {}

namespace {

// body(range) over [0, n) in blocks of at most `block` indices, checking
// `cancelled` before each block: simple_partitioner keeps the blocks that
// small (the default auto_partitioner hands out chunks of thousands, and a
// cancellation checked only per chunk would be noticed seconds late).
// Throws Cancelled once the rest has been skipped.
template <class Body>
void cancellable_for(size_t n, size_t block, const std::function<bool()>& cancelled, const Body& body) {
  std::atomic<bool> stop{false};
  tbb::task_group_context group;
  tbb::parallel_for(
      tbb::blocked_range<size_t>(0, n, block),
      [&](const tbb::blocked_range<size_t>& range) {
        if (stop.load(std::memory_order_relaxed)) return;
        if (cancelled && cancelled()) {
          stop = true;
          group.cancel_group_execution();
          return;
        }
        body(range);
      },
      tbb::simple_partitioner(), group);
  if (stop) throw Cancelled("gather cancelled by the client (disconnect or deadline)");
}

}  // namespace

void GatherPool::for_each(size_t n, const std::function<void(Gatherer&, size_t)>& body) {
  constexpr size_t kBlock = 64;  // receivers between cancellation checks
  cancellable_for(n, kBlock, cancelled_, [&](const tbb::blocked_range<size_t>& range) {
    // Created lazily: a thread that never gets a block allocates nothing.
    std::unique_ptr<Gatherer>& gatherer = gatherers_.local();
    if (!gatherer) {
      gatherer = std::make_unique<Gatherer>(tree_, options_);
      gatherer->set_volume_points(fog_);  // the scene's fog, if any
      gatherer->set_ray_scene(rays_);
    }
    for (size_t i = range.begin(); i != range.end(); ++i) body(*gatherer, i);
  });
}

void GatherPool::for_each(size_t n, const std::function<void(size_t)>& body) {
  constexpr size_t kBlock = 256;  // lookups are ~100 times cheaper than gathers
  cancellable_for(n, kBlock, cancelled_, [&](const tbb::blocked_range<size_t>& range) {
    for (size_t i = range.begin(); i != range.end(); ++i) body(i);
  });
}

GatherCounters GatherPool::counters() const {
  GatherCounters out;
  for (const auto& gatherer : gatherers_) {
    if (gatherer) out.add(gatherer->counters());
  }
  return out;
}

GatherBatch gather_receivers(const tree::TreeSource& tree, const std::vector<Receiver>& receivers,
                             const GatherOptions& options, const std::function<bool()>& cancelled,
                             std::shared_ptr<const VolumePoints> fog, const RayScene* rays) {
  const auto start = std::chrono::steady_clock::now();
  GatherBatch batch;
  batch.results.resize(receivers.size());
  GatherPool pool(tree, options, cancelled, std::move(fog), rays);
  pool.for_each(receivers.size(), [&](Gatherer& gatherer, size_t i) {
    batch.results[i] = gatherer.gather(receivers[i]);
  });
  batch.counters = pool.counters();
  batch.counters.receivers = receivers.size();  // whatever each gatherer counted
  batch.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return batch;
}

}  // namespace pbgi::service
