// The surfel section of a V8-V11 page of compact records (FORMAT.md): the
// page's 18-byte compact surfel records (page_records.h), stored column by
// column, bit-packed: each field of the record (position x, y, z, the two
// octahedral normal codes, the radius code, the emits flag, the albedo's
// and the radiance's three RGB9E5 mantissas and exponent) takes the
// fewest bits that tell its values in this page apart: the page stores
// the field's smallest value and the width of the differences to it.
// Lossless: the decoded records are the build's, bit for bit.
//
// V10/V11 pages (page_format_has_small_frame) code two fields anew, still
// losslessly:
//  * positions: the build puts a leaf's position codes on a grid of 2^s
//    codes when its surfels' radii allow (page_records.h
//    position_grid_shift: s = 4, 10 bits, on a surface sampled evenly), so
//    the section stores the page's common s (3 bits) and each code in
//    14 - s bits;
//  * the radius: as the difference to a prediction, the previous surfel's
//    radius code rescaled from its leaf's frame to this surfel's
//    (surfels of a page have about one radius in the world, but leaves of
//    several sizes): the first surfel's code in full, then each
//    difference, the column's smallest difference and width in its header.
// Measured on a generated city: 10.7 -> 8.1 bytes a surfel
// (docs/measurements/2026-11-28-page-format-v10.md).
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

// Appends the section of `records` (a whole number of compact records;
// none: nothing) to `out`, in the coding of page format `format` (V8-V11).
// `leaves` are the page's leaves, whose counts add up to the records (V10
// and V11 predict radii with their frames).
void encode_surfel_section(std::span<const uint8_t> records, std::span<const LeafRecord> leaves, uint32_t format,
                           std::vector<uint8_t>& out);

// Decodes the section of the records of `leaves` (their counts' sum) at the
// start of `bytes` into `records` (replaced: that many compact records), in
// the coding of page format `format`, and returns its
// size. Throws CorruptionError, prefixed with `what`, for a section that
// does not fit `bytes` or holds what no writer produces (a width beyond
// its field's, a value past its field, padding bits that are not zero).
size_t decode_surfel_section(std::span<const uint8_t> bytes, std::span<const LeafRecord> leaves, uint32_t format,
                             std::vector<uint8_t>& records, const std::string& what);

}  // namespace pbgi::storage
