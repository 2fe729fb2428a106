// A treelet <-> the bytes of one V4-V9 page (layout in FORMAT.md):
//   header | shapes | pad | leaf records | link records | payload array |
//   surfel records | emission entries (V6-V9) | glossy section | trailer
// V8-V11 pages (V10/V11 what this build writes; V4-V9 are read) hold the same
// parts in compact forms: nibble shapes, no pad, a leaf section
// (leaf_section.h), 26-byte link records, compact link payloads
// (payload_rounding.h), a surfel section (surfel_section.h).
// The payload array holds, through the page set's codec, the payloads of
// the linked children (the roots of other pages) in link order: what the
// nodes of this page need to derive their own payloads (V2). A treelet that
// carries stored payloads (Treelet::nodes, codes) is written as a V3 page
// whose payload array holds every node's payload in pre-order instead.
#pragma once

#include "storage/codecs/payload_codec.h"
#include "storage/format/page_frame.h"
#include "storage/tree/node.h"
#include "storage/tree/treelet.h"

#include <cstdint>
#include <span>
#include <vector>

namespace pbgi::storage {

// Serializes `t` as page `page_id` into `out` (replaced), sealed with its
// checksum. A non-empty `glossy` (storage/codecs/glossy_pages.h) is
// appended as the page's glossy radiance section (kPageFlagGlossy).
void encode_page(const tree::Treelet& t, uint32_t page_id, const PayloadCodec& codec,
                 std::vector<uint8_t>& out, std::span<const uint8_t> glossy = {});

// Where the parts of a decoded page lie: byte offsets from its start, in
// page order (FORMAT.md); each part ends where the next begins, the
// trailer at the page's end. For size breakdowns (benchmarks, inspection).
struct PageParts {
  uint64_t shapes = 0, leaves = 0, links = 0, payloads = 0, albedo = 0, surfels = 0, emission = 0, glossy = 0,
           trailer = 0;
};

// Verifies (checksum, header, sizes, shapes, links) and decodes the page at
// `where`, deriving every node's summary. Links must point to pages with a
// smaller id (written before). A glossy section is accepted only when
// `glossy_allowed` (the manifest declares glossy radiance) and decoded into
// Page::glossy. Surfel records are read in the layout of `leaf_format`
// (the manifest's) and the page's format (compact in V6/V7); a page whose
// kPageFlagHalfLeaves disagrees is refused. Throws
// CorruptionError naming the page, VersionError for an unknown page format.
std::shared_ptr<tree::Page> decode_page(std::span<const uint8_t> bytes, const PageLocation& where,
                                        uint32_t expected_version, const PayloadCodec& codec, uint32_t page_count,
                                        bool glossy_allowed = false, LeafFormat leaf_format = LeafFormat::kRelative,
                                        PageParts* parts = nullptr);
// The same into `out`, whose arrays are reused (a reader that decodes page
// after page into one scratch page allocates nothing once they are large
// enough). Everything in `out` is replaced except its attachment, which
// must be null.
void decode_page_into(std::span<const uint8_t> bytes, const PageLocation& where, uint32_t expected_version,
                      const PayloadCodec& codec, uint32_t page_count, bool glossy_allowed, LeafFormat leaf_format,
                      PageParts* parts, tree::Page& out);

}  // namespace pbgi::storage
