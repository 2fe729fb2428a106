// The surfel section of a V8/V9 page of compact records (FORMAT.md): the
// page's 18-byte compact surfel records (page_records.h), stored column by
// column, bit-packed: each field of the record (position x, y, z, the two
// octahedral normal codes, the radius code, the emits flag, the albedo's
// and the radiance's three RGB9E5 mantissas and exponent) takes the
// fewest bits that tell its values in this page apart: the page stores
// the field's smallest value and the width of the differences to it.
// Lossless: the decoded records are the build's, bit for bit.
//
// Why: a page's ~14 surfels lie on one or two surfaces, so their normals,
// radii (uniform sampling) and colours vary little; a shared albedo (V6's
// kPageFlagSharedAlbedo) is the case of an albedo column of width 0.
// Measured: 14.2 -> 8.3 bytes a surfel on the Cornell box, 14.0 -> 9.5 on
// a generated city (docs/measurements/2026-11-27-compact-v8.md).
//
// Thread-safety: pure functions.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace pbgi::storage {

// Appends the section of `records` (a whole number of compact records;
// none: nothing) to `out`.
void encode_surfel_section(std::span<const uint8_t> records, std::vector<uint8_t>& out);

// Decodes the section of `surfel_count` records at the start of `bytes`
// into `records` (replaced: surfel_count compact records) and returns its
// size. Throws CorruptionError, prefixed with `what`, for a section that
// does not fit `bytes` or holds what no writer produces (a width beyond
// its field's, a value past its field, padding bits that are not zero).
size_t decode_surfel_section(std::span<const uint8_t> bytes, size_t surfel_count, std::vector<uint8_t>& records,
                             const std::string& what);

}  // namespace pbgi::storage
