#include "server/engine/scene_memory.h"

#include "server/surfels/surfel_samplers.h"
#include "storage/pages/page_table.h"

#include <algorithm>

namespace pbgi {
namespace {

// Embree's peak while it builds (RTC_BUILD_QUALITY_MEDIUM, robust): its
// copies of the vertices (16 B each, padded) and indices (12 B a
// triangle), and per triangle the BVH and the build's primitive
// references. Measured by Embree's memory monitor (copies included): 83 B
// per triangle final, 116 B at the peak, on the generated 4M-triangle
// scene of docs/measurements/2026-11-27-daemon-budget.md (the estimate
// charged for it was 1.4x the peak).
constexpr uint64_t kRayBytesPerVertex = 16;
constexpr uint64_t kRayBytesPerTriangle = 12 + 110;
// Per instance: an instance geometry and its node in the top-level BVH.
constexpr uint64_t kRayBytesPerInstance = 512;
// The device, its thread-local allocators and empty scenes.
constexpr uint64_t kRayFixedBytes = uint64_t(8) << 20;
// A build's batches of surfels in flight (65 536 surfels a batch, sampled,
// shaded and sorted by the worker threads), page encoding and the
// bounce gather's receivers, the sort's zstd contexts (~2.4 MB,
// storage/pages/run_file.h), beside the sort memory. A bound chosen, not
// measured per part.
constexpr uint64_t kBuildBatchBytes = uint64_t(64) << 20;
// The least sort memory a build is given under a tight budget.
constexpr uint64_t kMinSortMemory = uint64_t(16) << 20;
// estimate_page_table_bytes(): the fewest surfels a page holds on the
// generated city and Cornell box, and the room the table's growth needs.
constexpr uint64_t kMinSurfelsPerPage = 12;
constexpr double kTableGrowthRoom = 2.5;
constexpr uint64_t kMinTableBytes = uint64_t(1) << 20;

}  // namespace

uint64_t estimate_ray_structure_bytes(const Scene& scene) {
  uint64_t triangles = scene.triangles.triangle_count();
  uint64_t vertices = scene.triangles.positions.size();
  for (const Prototype& p : scene.prototypes) {
    triangles += p.triangles.triangle_count();
    vertices += p.triangles.positions.size();
  }
  return kRayFixedBytes + vertices * kRayBytesPerVertex + triangles * kRayBytesPerTriangle +
         scene.instances.size() * kRayBytesPerInstance;
}

uint64_t estimate_build_bytes(const OpenOptions& options) { return options.tree.sort_memory_bytes + kBuildBatchBytes; }

uint64_t expected_surfels(const Scene& scene, const SurfelOptions& options) {
  if (options.spacing > 0.f && !options.adaptive()) {
    const double area = scene_area(scene).total;
    return uint64_t(std::min(1e18, area / (double(options.spacing) * options.spacing)));
  }
  return options.target_surfels;
}

uint64_t estimate_page_table_bytes(uint64_t surfels) {
  const uint64_t pages = surfels / kMinSurfelsPerPage + 1;
  return std::max(kMinTableBytes, uint64_t(kTableGrowthRoom * double(storage::PageTable::bytes_for(pages))));
}

uint64_t fit_sort_memory(const OpenOptions& options, uint64_t available, uint64_t table_bytes) {
  const uint64_t others = kBuildBatchBytes + table_bytes;
  const uint64_t room = available > others ? available - others : 0;
  return std::min(options.tree.sort_memory_bytes, std::max(kMinSortMemory, room));
}

}  // namespace pbgi
