// The random sample of surfels over which a kmeans-sh page-set build learns
// its LUT, drawn while the surfels stream in (they are never all in memory:
// they go to the external sort).
//
// Each surfel gets a pseudo-random priority from its arrival index alone
// (a hash with a fixed seed), so the sample depends on the surfels in
// arrival order, never on the batch sizes. The sample is every surfel whose
// priority is below `fraction`, or, if that gives fewer than `min_count`,
// the `min_count` surfels of lowest priority (all of them if fewer arrive):
// the "fraction, but at least min_count" rule of storage::sample_surfels()
// without knowing the total in advance. Memory: the sample plus at most
// 2 x min_count candidates.
//
// Thread-safety: one thread drives a collector.
#pragma once

#include "storage/tree/surfel.h"

#include <cstdint>
#include <span>
#include <vector>

namespace pbgi::storage {

class LutSampleCollector {
 public:
  // InvalidArgument unless fraction is in (0, 1].
  LutSampleCollector(double fraction, uint64_t min_count);

  // Offers the next surfels in arrival order.
  void add(std::span<const Surfel> surfels);
  // The sample in arrival order; the collector is spent afterwards.
  std::vector<Surfel> take();

  uint64_t offered() const { return offered_; }

 private:
  struct Candidate {
    double priority;
    uint64_t index;
    Surfel surfel;
  };
  void prune();

  double fraction_;
  uint64_t min_count_;
  uint64_t offered_ = 0;
  // Candidates with priority below `threshold_` (everything below
  // `fraction_` and, until pruned, the lowest others).
  std::vector<Candidate> kept_;
  double threshold_ = 1.0;
  size_t prune_at_;
};

}  // namespace pbgi::storage
