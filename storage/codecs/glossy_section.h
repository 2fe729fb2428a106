// The on-disk form of a page's glossy radiance (storage/codecs/glossy_pages.h):
// a wavelet tree code (wavelet_tree_coding.h) with one average (the page
// root's) and per-face detail blocks, stored compactly.
//
// Each block (one cube face: 3 n^2 Haar coefficients, r, g, b images) is
// stored as its largest magnitude `scale` (f32), a bitmap of the
// coefficients that are not zero at half precision, and those
// coefficients divided by `scale` as IEEE half floats. Haar coefficients of
// a lobe are mostly zero (a lobe covers a few pixels of a face), so the
// bitmap keeps blocks small; the half floats bound each coefficient's error
// by 2^-11 x scale (relative to the block's largest coefficient, so HDR
// blocks keep their relative accuracy and never overflow half's range).
//
// Layout (little-endian), FORMAT.md "Glossy radiance section":
//   u32 magic 'PBGR', u32 version (1), u32 resolution n (8, 16, 32),
//   u32 node_count, f32 threshold,
//   u8 per node: bits 0-5 the faces whose detail block is kept, bit 7 the
//     node has a detail slot (two children),
//   the root average's 6 blocks, then every kept detail block in node
//   order (faces ascending), each: f32 scale, ceil(3 n^2 / 8) bitmap bytes
//   (LSB first), one f16 per set bit;
//   u64 XXH3-64 of everything before it.
//
// Thread-safety: pure functions.
#pragma once

#include "storage/codecs/wavelet_tree_coding.h"
#include "storage/format/format_version.h"

#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace pbgi::storage {

inline constexpr uint32_t kGlossySectionMagic = fourcc("PBGR");
inline constexpr uint32_t kGlossySectionV1 = 1;

// `code` must have average_levels 0 and one block per cube face of
// resolution n (InvalidArgument otherwise).
std::vector<uint8_t> write_glossy_section(const WaveletTreeCode& code, uint32_t n);

// The code back (values rounded to what was stored); `n` receives the
// resolution. CorruptionError (prefixed with `what`) for damaged bytes,
// VersionError for another version.
WaveletTreeCode read_glossy_section(std::span<const uint8_t> bytes, const std::string& what, uint32_t& n);

}  // namespace pbgi::storage
