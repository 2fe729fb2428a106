// The leaf section of a V8-V11 page (FORMAT.md): the frames and surfel
// counts of the page's leaves, in pre-order, bit-packed. The tree's frames
// are rounded (page_records.h RoundedFrame: k 2^e per centre coordinate,
// m 2^e radius), so they are stored exactly, as integers: the first
// leaf's in full, every other leaf's exponent as the difference to the
// previous leaf's and its centre as the difference between k and the
// previous leaf's centre on this leaf's grid (leaves of a page are
// neighbours in Morton order, so the differences are small), each field
// with the fewest bits any leaf of the page needs (three width bytes
// first). A page whose differences would need more than 25 bits stores
// every centre in full instead (a flag).
//
// Measured on a generated city (docs/measurements/2026-11-27-compact-v8.md):
// 2.9 bytes per surfel against 6.1 for V6's 18-byte records.
//
// Thread-safety: pure functions.
#pragma once

#include "storage/tree/page_records.h"

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace pbgi::storage {

// Appends the section of `leaves` (none: nothing) to `out`. Throws Error
// for a frame that is not rounded or a count outside [1,
// kMaxCompactLeafSurfels] (a writer's bug).
void encode_leaf_section(std::span<const LeafRecord> leaves, std::vector<uint8_t>& out);

// Decodes the section of `leaf_count` leaves at the start of `bytes` into
// `out` (replaced) and returns its size in bytes. Throws CorruptionError,
// prefixed with `what`, for a section that does not fit `bytes` or holds
// what no writer produces (widths or reserved bits out of range, an
// exponent outside [-126, 115], a centre beyond the i24 range or float
// range, a radius past 12 bits).
size_t decode_leaf_section(std::span<const uint8_t> bytes, size_t leaf_count, std::vector<LeafRecord>& out,
                           const std::string& what);

}  // namespace pbgi::storage
