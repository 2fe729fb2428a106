// What an open scene costs in memory outside the page cache, as the
// daemon's memory accountant (memory_accountant.h) is charged for it:
// estimated before each part is allocated, so that a scene that cannot fit
// is refused first, then replaced by the measured size.
//
// The estimates are upper bounds of what was measured on generated scenes
// (docs/measurements/2026-11-27-daemon-budget.md): Embree's BVH at
// RTC_BUILD_QUALITY_MEDIUM with its copies of vertices and indices peaks at
// about 1.4 times its final size while it builds; a page-set build holds its
// sort memory (BuildOptions::sort_memory_bytes) and its batches of surfels.
#pragma once

#include "server/engine/open_options.h"
#include "server/scene/scene.h"

#include <cstdint>

namespace pbgi {

// Peak bytes Embree needs to build the ray-tracing structure of `scene`
// (world triangles and each prototype once; instances at their own cost).
uint64_t estimate_ray_structure_bytes(const Scene& scene);

// Bytes a page-set build of `options` holds beside the scene while it runs,
// apart from its page table, which is charged as it grows
// (storage::PageSetBuilder::set_memory_hook).
uint64_t estimate_build_bytes(const OpenOptions& options);

// About how many surfels a build of `options` samples on `scene`: the
// scene's area over the spacing squared, or the target count when the
// spacing is derived from it or varies (adaptive).
uint64_t expected_surfels(const Scene& scene, const SurfelOptions& options);

// What a build's page table may hold at its largest for `surfels` surfels,
// kept free of the sort memory so that the table can grow: pages of at
// least 12 surfels (14.3 at 1 G surfels, 12.8 on the 2M city), ~2.25
// bytes a page (storage/pages/page_table.h), 2.5 times that while the
// table grows (its old arrays and the new ones, half as large again); at
// least 1 MiB.
uint64_t estimate_page_table_bytes(uint64_t surfels);

// The sort memory for a build when `available` bytes of the budget are
// free: the option's, or less when the budget cannot give it beside the
// build's batches and `table_bytes` for its page table (down to 16 MiB;
// more runs go to disk). It changes the build's speed and memory, never
// its page set (it is not part of build keys).
uint64_t fit_sort_memory(const OpenOptions& options, uint64_t available, uint64_t table_bytes);

}  // namespace pbgi
