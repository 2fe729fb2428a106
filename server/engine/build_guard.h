// What stops a page-set build before it is done: every client waiting for
// it has gone (a disconnect, a deadline, the daemon shutting down), or it
// would pass the daemon's bound on the surfels of one build
// (EngineContext::max_surfels). The staging quota, the bound on its disk,
// is charged by the page-set builder itself (storage/pages/staging_quota.h).
//
// The build polls the guard between surfel batches, merge percents and
// gather batches, so it stops within one batch (well under a second at the
// default 65 536 surfels per batch); what it has staged is then removed
// with its staging directory.
#pragma once

#include "server/scene/scene.h"
#include "server/surfels/surfel_options.h"

#include <cstdint>
#include <functional>
#include <string>

namespace pbgi {

// True once the work should stop; polled, never waited on. Must be
// callable from the build's thread.
using CancelledFn = std::function<bool()>;

// Not thread-safe: one build thread polls it.
class BuildGuard {
 public:
  // `max_surfels` 0: no bound. `cancelled` empty: never cancelled.
  BuildGuard(std::string scene_path, uint64_t max_surfels, CancelledFn cancelled);

  // Throws Cancelled naming the scene if `cancelled` says so.
  void check_cancelled() const;

  // Before the scene is read: throws ResourceExhausted naming
  // limits.max_surfels if `options` ask for more than `max_surfels` by
  // count (target_surfels, when no spacing is given). 0: no bound.
  static void check_target(const SurfelOptions& options, uint64_t max_surfels);

  // Before sampling: check_target(), and for a given absolute spacing the
  // same for the scene's area at that spacing. A camera-adaptive spacing
  // has no estimate before sampling: count() bounds it.
  void check_expected(const Scene& scene, const SurfelOptions& options) const;

  // After each batch of `n` surfels: throws ResourceExhausted once the
  // build has produced more than the bound plus a tolerance of 1% (the
  // sampled count of an absolute spacing differs from its estimate by
  // rounding per triangle: a request at the bound must not fail at the
  // end), and Cancelled as check_cancelled().
  void count(uint64_t n);

 private:
  std::string scene_path_;
  uint64_t max_surfels_;
  CancelledFn cancelled_;
  uint64_t surfels_ = 0;
};

}  // namespace pbgi
