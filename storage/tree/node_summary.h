// The summary of a node (bounds, normal cone, area, payload; node.h) from
// what lies below it: a leaf's from its decoded surfels, an internal node's
// from its children's summaries. The tree build and the page reader both
// call these, on the same values in the same order, so a node derived when
// a page loads is bit-identical to the node the build computed (V2 pages
// store only what cannot be derived: see storage/format/FORMAT.md).
//
// Thread-safety: pure functions.
#pragma once

#include "storage/tree/node.h"
#include "storage/tree/page_records.h"
#include "storage/tree/surfel.h"

#include <cstdint>
#include <span>

namespace pbgi::tree {

// What a summary does with the SH payload:
//   kNone     leaves it alone (pages that store every node's payload); the
//             area is the same as with a payload;
//   kExact    the area-weighted average in float (V4/V5 page sets);
//   kRounded  that average rounded by round_payload() (payload_rounding.h):
//             the trees this build writes (V6/V7 pages, in-memory trees).
enum class PayloadMode : uint8_t { kNone, kExact, kRounded };

// What a summary does with the bounds (sphere and cone):
//   kExact    the enclosing sphere and cone as computed (V4-V7 page sets);
//   kRounded  those rounded outward by bounds_rounding.h: the trees this
//             build writes (V8/V9 pages, in-memory trees). A leaf's sphere
//             is its frame, rounded already (leaf_quantizer.h).
enum class BoundsMode : uint8_t { kExact, kRounded };

// Leaf over `surfels` (decoded, non-empty) stored in `frame`: sphere =
// frame, cone around the normals, area and payload from the surfels. Sets
// child_count = 0 and surfel_count; leaves first_surfel alone.
void summarize_leaf(std::span<const Surfel> surfels, const storage::LeafFrame& frame, Node& out, PayloadMode payload,
                    BoundsMode bounds);

// Internal node over one or two children (`b` may be null): enclosing
// sphere and cone, summed area, area-weighted payload. Sets child_count;
// leaves the child links alone. One child: its bounds, as they are.
void summarize_internal(const Node& a, const Node* b, Node& out, PayloadMode payload, BoundsMode bounds);

}  // namespace pbgi::tree
