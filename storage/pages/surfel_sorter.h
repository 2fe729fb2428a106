// External sort of surfels by (air region, Morton code, arrival index)
// under a hard memory bound, so that a page set of any size is built from a
// sorted stream (storage/tree/streaming_tree_builder.h). Regions
// (storage/tree/region_grid.h) sort first so that each region's surfels
// form one run of the stream, and so one subtree.
//
// Surfels are copied into a run buffer of memory_bytes; a full buffer is
// sorted and written to a run file in `run_dir`. drain() streams the sorted
// sequence: straight from the buffer when nothing was spilled, else by
// k-way merges of the runs (intermediate passes when there are more runs
// than the fan-in), each run read through a buffer of one block. The run
// buffer, the merge buffers and the compressed blocks in flight never
// exceed memory_bytes together (zstd's own state, ~2.4 MB at the default
// memory, is beside it), and the order never depends on it: ties in code
// are broken by arrival index.
//
// Run files are temporary (run_file.h: zstd-compressed blocks, ~20 bytes a
// surfel on the generated city instead of 96, each with a checksum;
// deleted as soon as merged); `run_dir` is the build's staging directory,
// so a crashed build leaves nothing that outlives its staging directory.
//
// Thread-safety: one sorter per build; not thread-safe.
#pragma once

#include "storage/tree/morton.h"
#include "storage/tree/surfel.h"

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <span>

namespace pbgi::storage {

class StagingUsage;

// Runs merged at once unless a caller asks for fewer.
inline constexpr uint32_t kDefaultSortFanIn = 64;
// Regions share a 64-bit word with the arrival index (< 2^40).
inline constexpr uint32_t kMaxSortedRegion = (1u << 24) - 1;

struct SortStats {
  uint64_t surfels = 0;
  uint32_t runs = 0;           // runs written to disk (0: sorted in memory)
  uint32_t merges = 0;         // k-way merges of runs, the last (feeding the caller) included
  uint64_t run_bytes = 0;      // bytes written to run files (compressed), all passes
  uint64_t peak_bytes = 0;     // largest total of run and merge buffers held
};

class SurfelSorter {
 public:
  // `memory_bytes` >= 64 KiB. `max_fan_in` (>= 2) caps the runs merged at
  // once (tests lower it to force several passes). `usage` (may be null;
  // must outlive the sorter) is charged for each block before it is
  // written to a run file (ResourceExhausted past its quota) and released
  // as run files are deleted.
  SurfelSorter(const tree::MortonFrame& frame, uint64_t memory_bytes, std::filesystem::path run_dir,
               uint32_t max_fan_in = kDefaultSortFanIn, StagingUsage* usage = nullptr);
  ~SurfelSorter();  // deletes remaining run files
  SurfelSorter(const SurfelSorter&) = delete;
  SurfelSorter& operator=(const SurfelSorter&) = delete;

  // Appends surfels in arrival order (already checked; regions below
  // kMaxSortedRegion). Spills full runs.
  void add(std::span<const Surfel> surfels);

  // Calls `emit(surfel, code)` for every surfel in (region, code, arrival) order;
  // `progress(fraction)` after each percent of the surfels of every merge
  // pass, the passes splitting [0, 1] by their data. The sorter is spent
  // afterwards. Exceptions of the callbacks propagate.
  void drain(const std::function<void(const Surfel&, uint64_t)>& emit,
             const std::function<void(float)>& progress = {});

  const SortStats& stats() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace pbgi::storage
