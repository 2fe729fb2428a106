// The frame around every page of pages.pbgp: a fixed 32-byte header that says
// what the page holds, and an 8-byte trailer with the XXH3-64 checksum of all
// bytes before it. What lies between (topology, payload, surfels) is written
// by storage/pages; this file only knows sizes.
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

inline constexpr size_t kPageHeaderBytes = 32;
inline constexpr size_t kPageTrailerBytes = 8;

struct PageHeader {
  uint32_t magic = kPageMagic;
  uint16_t format_version = kPageFormatCurrent;
  uint16_t codec = 0;          // payload codec id (storage/codecs)
  uint32_t page_id = 0;
  uint32_t node_count = 0;
  uint32_t surfel_count = 0;
  uint32_t payload_bytes = 0;  // size of the payload array
  uint32_t page_bytes = 0;     // whole page: header + arrays + trailer
  uint32_t flags = 0;          // kPageFlag* bits (format_version.h): V2 and V3
};

// Where a page lives, for error messages.
struct PageLocation {
  std::string file;
  uint32_t page_id = 0;
  uint64_t offset = 0;  // file offset of the page's first byte
  std::string describe() const;  // "<file>: page 7 at offset 123 (4096 bytes)"-style prefix
};

// Writes the 32-byte header at out.
void write_page_header(const PageHeader& h, uint8_t* out);
// Decodes the header at in; no checks.
PageHeader read_page_header(const uint8_t* in);

// Computes the checksum of page[0, size - 8) and stores it in the trailer.
void seal_page(std::span<uint8_t> page);

// Why page format `version` is not read (for a VersionError after the
// file/page context): retired formats ask for a rebuild.
std::string unsupported_page_format(uint32_t version);

// Verifies a page read from `where`: size, checksum, magic, format version
// (must be `expected_version`, the one the manifest declares), page id and
// page_bytes. Returns its header. The checksum is checked first so that any
// damaged byte, wherever it is, reports as corruption of this page.
PageHeader open_page(std::span<const uint8_t> page, const PageLocation& where,
                     uint32_t expected_version);

}  // namespace pbgi::storage
