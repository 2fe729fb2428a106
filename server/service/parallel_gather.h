// Gathers many receivers over TBB: one Gatherer per worker thread (it owns
// its microbuffer), receivers split in blocks, counters summed at the end.
#pragma once

#include "server/gather/gather.h"

#include <tbb/enumerable_thread_specific.h>

#include <cstddef>
#include <functional>
#include <memory>
#include <vector>

namespace pbgi::service {

struct GatherBatch {
  std::vector<GatherResult> results;   // one per receiver, in order
  GatherCounters counters;             // counters.receivers: the gathers made
  double seconds = 0;
};

// The thread-local Gatherers of one request, kept across its passes (an
// interpolated gather runs several). Thread-safe in for_each() (reads
// `tree` concurrently); everything else from one thread.
class GatherPool {
 public:
  // `rays`: the scene's geometry (the receivers' air regions, depth caps;
  // Gatherer::set_ray_scene), or null.
  GatherPool(const tree::TreeSource& tree, const GatherOptions& options, std::function<bool()> cancelled,
             std::shared_ptr<const VolumePoints> fog, const RayScene* rays = nullptr);

  // Calls body(gatherer, i) for i in [0, n) over all cores, in blocks; a
  // Gatherer is made lazily per worker thread. Polls `cancelled` between
  // blocks and throws pbgi::Cancelled once it returns true; errors of the
  // tree (IoError, CorruptionError) and of body propagate.
  void for_each(size_t n, const std::function<void(Gatherer&, size_t)>& body);
  // The same without a Gatherer (for work that only reads results).
  void for_each(size_t n, const std::function<void(size_t)>& body);

  // The counters of every Gatherer so far.
  GatherCounters counters() const;

 private:
  const tree::TreeSource& tree_;
  GatherOptions options_;
  std::function<bool()> cancelled_;
  std::shared_ptr<const VolumePoints> fog_;
  const RayScene* rays_;
  tbb::enumerable_thread_specific<std::unique_ptr<Gatherer>> gatherers_;
};

// Gathers every receiver. Thread-safe (reads `tree` concurrently).
// `cancelled` is polled from worker threads between blocks; once it
// returns true the batch stops and pbgi::Cancelled is thrown. Errors of the
// tree (IoError, CorruptionError) propagate.
GatherBatch gather_receivers(const tree::TreeSource& tree, const std::vector<Receiver>& receivers,
                             const GatherOptions& options, const std::function<bool()>& cancelled = {},
                             std::shared_ptr<const VolumePoints> fog = nullptr, const RayScene* rays = nullptr);

}  // namespace pbgi::service
