// Gathers many receivers over TBB: one Gatherer per worker thread (it owns
// its microbuffer), receivers split in blocks, counters summed at the end.
#pragma once

#include "server/gather/gather.h"

#include <functional>
#include <memory>
#include <vector>

namespace pbgi::service {

struct GatherBatch {
  std::vector<GatherResult> results;   // one per receiver, in order
  GatherCounters counters;
  double seconds = 0;
};

// Thread-safe (reads `tree` concurrently). `cancelled` is polled from
// worker threads between blocks; once it returns true the batch stops and
// pbgi::Cancelled is thrown. Errors of the tree (IoError,
// CorruptionError) propagate.
GatherBatch gather_receivers(const tree::TreeSource& tree, const std::vector<Receiver>& receivers,
                             const GatherOptions& options,
                             const std::function<bool()>& cancelled = {},
                             std::shared_ptr<const VolumePoints> fog = nullptr);

}  // namespace pbgi::service
