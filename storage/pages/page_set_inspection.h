// Statistics of a page set for `pbgi inspect` and benchmarks: what the
// manifest says, what the page table says (fill), and what a full walk of
// the tree finds (depths, pages per root-to-leaf path). The walk reads and
// verifies every reachable page, so it doubles as a consistency check.
#pragma once

#include "storage/pages/page_set.h"

#include <cstdint>
#include <string>

namespace pbgi::storage {

struct PageSetInspection {
  // Record sizes on disk (page format V2, FORMAT.md): every node takes a
  // shape byte; a leaf adds a leaf record, a child in another page a link
  // record plus its payload. Other nodes' bounds and payloads are derived
  // at load, so no per-node payload is stored (V3: every node stores one,
  // links none).
  bool node_payloads = false;
  // V8/V9 pages: the shapes are nibbles, and the leaf frames, the surfel
  // records and the linked children's payloads are bit-packed per page, so
  // their sizes vary from page to page (FORMAT.md).
  bool packed_sections = false;
  double topology_bytes_per_node = 0;    // the shape byte (a nibble when packed)
  uint64_t payload_bytes_per_node = 0;   // 0: derived, or variable (kmeans-sh)
  uint64_t surfel_record_bytes = 0;      // before packing, when packed
  uint64_t leaf_record_bytes = 0;        // 0: packed
  uint64_t link_record_bytes = 0;        // without the payload
  uint64_t link_payload_bytes = 0;       // codec bytes per link; 0: packed (varies)
  std::string codec_name;

  // Page table.
  uint64_t page_bytes_total = 0;  // sum of page sizes (without alignment padding)
  uint64_t padding_bytes = 0;     // file bytes between pages
  double fill_mean = 0, fill_min = 0, fill_max = 0;  // page bytes / options.page_size

  // Walk (zero if not walked).
  bool walked = false;
  uint64_t nodes = 0, leaves = 0, surfels = 0;
  uint32_t pages_reached = 0;
  uint32_t leaf_depth_min = 0, leaf_depth_max = 0;
  double leaf_depth_mean = 0;
  double leaf_surfels_mean = 0;
  uint32_t path_pages_max = 0;    // pages touched from the root to a leaf
  double path_pages_mean = 0;
  // Walk results agree with the manifest's stats.
  bool consistent = true;
};

// Throws what PageSetReader::page() throws when a page is damaged.
PageSetInspection inspect_page_set(const PageSetReader& reader, bool walk = true);

}  // namespace pbgi::storage
