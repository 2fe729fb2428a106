#include "server/service/parallel_gather.h"

#include "storage/format/errors.h"

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>
#include <tbb/task_group.h>

#include <atomic>
#include <chrono>
#include <memory>

namespace pbgi::service {

GatherBatch gather_receivers(const tree::TreeSource& tree, const std::vector<Receiver>& receivers,
                             const GatherOptions& options,
                             const std::function<bool()>& cancelled,
                             std::shared_ptr<const VolumePoints> fog) {
  const auto start = std::chrono::steady_clock::now();
  GatherBatch batch;
  batch.results.resize(receivers.size());

  // Created lazily: a thread that never gets a block allocates nothing.
  tbb::enumerable_thread_specific<std::unique_ptr<Gatherer>> gatherers;
  std::atomic<bool> stop{false};
  tbb::task_group_context group;
  constexpr size_t kBlock = 64;  // receivers between cancellation checks
  // simple_partitioner: blocks of at most kBlock receivers. The default
  // auto_partitioner hands out chunks of thousands, and a cancellation
  // checked only per chunk would be noticed seconds late.

  tbb::parallel_for(
      tbb::blocked_range<size_t>(0, receivers.size(), kBlock),
      [&](const tbb::blocked_range<size_t>& range) {
        if (stop.load(std::memory_order_relaxed)) return;
        if (cancelled && cancelled()) {
          stop = true;
          group.cancel_group_execution();
          return;
        }
        std::unique_ptr<Gatherer>& gatherer = gatherers.local();
        if (!gatherer) {
          gatherer = std::make_unique<Gatherer>(tree, options);
          gatherer->set_volume_points(fog);  // the scene's fog, if any
        }
        for (size_t i = range.begin(); i != range.end(); ++i) {
          batch.results[i] = gatherer->gather(receivers[i]);
        }
      },
      tbb::simple_partitioner(), group);

  if (stop) throw Cancelled("gather cancelled by the client (disconnect or deadline)");
  for (const auto& gatherer : gatherers) {
    if (gatherer) batch.counters.add(gatherer->counters());
  }
  batch.counters.receivers = receivers.size();  // whatever each gatherer counted
  batch.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return batch;
}

}  // namespace pbgi::service
