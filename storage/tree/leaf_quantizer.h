// Turns the surfels of a leaf into surfel records of a page's layout, relative
// to the leaf's frame (storage/tree/page_records.h), and back.
//
// The frame is the bounding sphere of the surfel disks, widened until every
// *decoded* disk lies inside it: the tree's bounds are computed from the
// decoded surfels, so they hold for exactly what a reader gets. The frame
// radius is at most ~0.05% larger than the tightest sphere of the input,
// then rounded outward (page_records.h RoundedFrame, on the leaf frames' grid
// of kLeafFrameGridBits: up to ~1.5% more),
// so that a V8-V11 page's leaf section holds it exactly.
//
// Thread-safety: pure functions.
#pragma once

#include "storage/tree/page_records.h"
#include "storage/tree/surfel.h"

#include <cstdint>
#include <span>
#include <vector>

namespace pbgi::tree {

// Encodes `surfels` (non-empty, finite, unit normals, radius >= 0) into
// `records` (surfels.size() * surfel_record_bytes(layout) bytes) and writes
// what a reader will decode into `decoded` (same size). Records that keep
// the emission out of line (compact) append the emitting surfels' entries,
// in surfel order, to `emission`. Returns the frame.
storage::LeafFrame quantize_leaf(storage::SurfelRecords layout, std::span<const Surfel> surfels, uint8_t* records,
                                 std::span<Surfel> decoded, std::vector<uint8_t>& emission);

}  // namespace pbgi::tree
