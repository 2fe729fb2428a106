// The frame around every page of pages.pbgp: a header that says what the
// page holds (32 bytes in V4-V7 pages; 14 in V8, 18 in V9: the compact
// header keeps the magic, version, codec, flags, page id and node count and
// drops what the page table or the shapes give; 9 in V10, 13 in V11: the
// small header drops the codec, the manifest's, and the page id), and a
// trailer with the checksum of all bytes before it: the XXH3-64 (8 bytes,
// V4-V9), or the low 32 bits of the XXH3-64 seeded with the page id
// (4 bytes, V10/V11: a page read in another page's place fails its
// checksum, which is how the page id is still checked). What lies between
// (topology, payload, surfels) is written by storage/pages; this file only
// knows sizes.
//
// Errors: open_page() throws CorruptionError naming the file, page id, file
// offset, and the expected and found values; VersionError for a page format
// this build does not read.
#pragma once

#include "storage/format/format_version.h"

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

namespace pbgi::storage {

inline constexpr size_t kPageHeaderBytes = 32;         // V4-V7
inline constexpr size_t kCompactPageHeaderBytes = 14;  // V8; V9 adds a u32 payload_bytes
inline constexpr size_t kSmallPageHeaderBytes = 9;     // V10; V11 adds a u32 payload_bytes
inline constexpr size_t kPageTrailerBytes = 8;         // V4-V9
inline constexpr size_t kSmallPageTrailerBytes = 4;    // V10/V11
inline constexpr size_t kMinPageFrameBytes = kSmallPageHeaderBytes + kSmallPageTrailerBytes;
// Every header starts with the magic (u32) and the format version (u16).
inline constexpr size_t kPageVersionPrefixBytes = 6;
// The header size of page format `version` (a known one).
constexpr size_t page_header_bytes(uint32_t version) {
  if (!page_format_has_compact_frame(version)) return kPageHeaderBytes;
  const size_t base = page_format_has_small_frame(version) ? kSmallPageHeaderBytes : kCompactPageHeaderBytes;
  return base + (page_format_stores_node_payloads(version) ? 4 : 0);
}
// The trailer size of page format `version`.
constexpr size_t page_trailer_bytes(uint32_t version) {
  return page_format_has_small_frame(version) ? kSmallPageTrailerBytes : kPageTrailerBytes;
}
// The most nodes a compact header counts (u16); a V8/V9 page never holds
// more (kMaxPageLevels levels of at most two children: 2^16 - 1 nodes).
inline constexpr uint32_t kMaxCompactPageNodes = 65535;

// The fields of any page header. V8/V9 headers do not store surfel_count,
// page_bytes nor (V8) payload_bytes: read_page_header leaves them 0,
// open_page sets page_bytes to the page's size, the page decoder counts
// the rest from the shapes and leaf records; writers of V8/V9 headers
// ignore them.
struct PageHeader {
  uint32_t magic = kPageMagic;
  uint16_t format_version = kPageFormatCurrent;
  uint16_t codec = 0;  // payload codec id (storage/codecs); u8 in V8/V9
  uint32_t page_id = 0;
  uint32_t node_count = 0;     // u16 in V8/V9
  uint32_t surfel_count = 0;   // not stored in V8/V9
  uint32_t payload_bytes = 0;  // size of the payload array; not stored in V8
  uint32_t page_bytes = 0;     // whole page: header + arrays + trailer; not stored in V8/V9
  uint32_t flags = 0;          // kPageFlag* bits (format_version.h); u8 in V8/V9
};

// Where a page lives, for error messages.
struct PageLocation {
  std::string file;
  uint32_t page_id = 0;
  uint64_t offset = 0;  // file offset of the page's first byte
  std::string describe() const;  // "<file>: page 7 at offset 123 (4096 bytes)"-style prefix
};

// Writes the header of h.format_version's layout at out
// (page_header_bytes(h.format_version) bytes). Throws Error if a field
// does not fit a compact header (a writer's bug).
void write_page_header(const PageHeader& h, uint8_t* out);
// Decodes the header at in, in the layout of the version it names (the
// caller ensures page_header_bytes of that version are readable; an
// unknown version reads as a 32-byte header); no checks.
PageHeader read_page_header(const uint8_t* in);

// Computes the checksum of everything before the trailer of the page (of
// the format its header names) and stores it in the trailer. `page_id`
// seeds the checksum of V10/V11 pages, whose header does not hold it.
void seal_page(std::span<uint8_t> page, uint32_t page_id = 0);

// Why page format `version` is not read (for a VersionError after the
// file/page context): retired formats ask for a rebuild.
std::string unsupported_page_format(uint32_t version);

// Verifies a page read from `where`: size, checksum, magic, format version
// (must be `expected_version`, the one the manifest declares), page id and
// page_bytes. Returns its header (V10/V11: page_id and codec are where's
// and 0: the checksum, seeded with where.page_id, vouches for the id). The
// checksum is checked first so that any damaged byte, wherever it is,
// reports as corruption of this page; it is the trailer of
// `expected_version`'s frame.
PageHeader open_page(std::span<const uint8_t> page, const PageLocation& where,
                     uint32_t expected_version);

}  // namespace pbgi::storage
