// Gathers a list of receivers in parallel with the tile's shared cache:
// PBGI in blocks of 64 receivers gathered one at a time (Gatherer::
// gather_tile: the block's pages stay pinned), factorized PBGI in batches
// of 1024 (in the given order, so that neighbours in the list share their
// far light).
#pragma once

#include "server/gather/gather.h"

#include <functional>
#include <memory>
#include <span>

namespace pbgi {

struct BatchGatherInput {
  const tree::TreeSource& tree;
  const GatherOptions& options;
  std::shared_ptr<GatherCache> cache;
  std::shared_ptr<const VolumePoints> fog;
  // The scene's geometry for the gather's depth caps
  // (GatherOptions::ray_depth_caps); null = none.
  const RayScene* rays = nullptr;
  // Called between blocks of receivers; throws to stop (Cancelled).
  std::function<void()> check_cancelled;
};

// results[i] = the gather at receivers[i]; adds the gatherers' counters.
void gather_receivers(const BatchGatherInput& in, std::span<const Receiver> receivers,
                      std::span<GatherResult> results, GatherCounters& counters);

}  // namespace pbgi
