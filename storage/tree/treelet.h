// A treelet as a V4-V7 page stores it (storage/format/FORMAT.md): the shapes
// of its nodes in pre-order, the frames of its leaves, the links to
// children in other pages (with those children's summaries), the
// quantized surfel records and (compact records) the emission entries of
// the surfels that emit. Nothing else: bounds, cones, areas and payloads
// of the nodes inside are derived by expand_treelet(), with the same
// functions the build used, so they are bit-identical to the build's.
//
// Thread-safety: values; expand_treelet() is reentrant.
#pragma once

#include "storage/tree/node.h"
#include "storage/tree/page_records.h"

#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace pbgi::tree {

// A child in another page: that page (whose root, index 0, is the child)
// and the child's summary (center, radius, cone, area, payload).
struct TreeletLink {
  uint32_t page = 0;
  Node summary;
};

// Borrowed view of a treelet's parts.
struct TreeletView {
  std::span<const uint8_t> shapes;          // storage::kShapeBytes per node
  std::span<const uint8_t> leaf_records;    // storage::kLeafRecordBytes per leaf (V4-V7 pages, the build)
  std::span<const TreeletLink> links;       // in the order the parse meets them
  std::span<const uint8_t> surfel_records;  // surfel_record_bytes(records) per surfel
  storage::SurfelRecords records = storage::SurfelRecords::kCompact;
  // Compact records: kEmissionEntryBytes per record that emits, in surfel
  // order (empty otherwise).
  std::span<const uint8_t> emission;
  // kCompactSharedAlbedo records: every surfel's RGB9E5 albedo.
  uint32_t shared_albedo = 0;
  // Pages that store every node's payload: one decoded node per node, in
  // pre-order, whose radiance_sh and coverage_sh are taken instead of
  // derived. Empty: payloads are derived from the surfels and links.
  std::span<const Node> payloads;
  // Most levels the treelet may span (storage::kMaxPageLevels for V4-V7
  // pages); 0: unbounded.
  uint32_t max_levels = 0;
  // Derived payloads are rounded (payload_rounding.h: V6-V9 pages and the
  // trees this build makes) or exact (V4/V5 pages).
  bool rounded_payloads = true;
  // Derived bounds are rounded (bounds_rounding.h: V8/V9 pages and the
  // trees this build makes) or exact (V4-V7 pages).
  bool rounded_bounds = true;
  // V8/V9 pages: the leaves' frames and counts, decoded from the page's
  // leaf section, used instead of leaf_records (then empty).
  std::span<const storage::LeafRecord> leaves;
};

// An owning treelet, as the builder hands it to a page writer.
struct Treelet {
  std::vector<uint8_t> shapes;
  std::vector<uint8_t> leaf_records;
  std::vector<TreeletLink> links;
  std::vector<uint8_t> surfel_records;
  storage::SurfelRecords records = storage::SurfelRecords::kCompact;
  std::vector<uint8_t> emission;  // the emitting surfels' entries (compact records)
  // Builds that store every node's payload (NodePayloadSizer): each node's
  // summary with its exact payload, in pre-order, for the page's codec.
  // Empty otherwise.
  std::vector<Node> nodes;
  // Pages with a glossy surfel: every surfel's lobe, in surfel order (the
  // page writer turns them into the page's wavelet radiance); else empty.
  std::vector<SurfelGloss> gloss;

  TreeletView view() const {
    return {shapes, leaf_records, links, surfel_records, records, emission, 0, {}, 0, true, true, {}};
  }
  size_t node_count() const { return shapes.size(); }
  size_t surfel_count() const;
  void clear();
};

// Decodes `t` into `out` (replaced): nodes in pre-order with page-relative
// links ({page_id, index} inside, {link.page, 0} outside), surfels in leaf
// order, every summary derived bottom-up. The parse visits a node, then
// all of child 0 (or its link), then all of child 1: links are consumed in
// that order. Throws CorruptionError, prefixed with `what`, when the parts
// disagree (a bad shape byte, counts that do not add up, an empty leaf,
// emission entries that do not match the records that emit, a
// link to a page id >= page_id: pages only link to pages written before
// them, so no chain of links can cycle).
void expand_treelet(const TreeletView& t, uint32_t page_id, const std::string& what, Page& out);

}  // namespace pbgi::tree
