// A decoded tree::Page <-> the bytes of one V1 page:
//   header | topology records | payload array (codec) | surfel records | trailer
// Topology is stored apart from the payload so that a later reader can load
// the topology alone, or swap the payload codec, without touching the rest.
#pragma once

#include "storage/codecs/payload_codec.h"
#include "storage/format/page_frame.h"
#include "storage/tree/node.h"

#include <cstdint>
#include <span>
#include <vector>

namespace pbgi::storage {

// Serializes `page` into `out` (replaced), sealed with its checksum.
// Child links and first_surfel must already be page-relative.
void encode_page(const tree::Page& page, const PayloadCodec& codec, std::vector<uint8_t>& out);

// Verifies (checksum, header, sizes, links) and decodes the page at `where`.
// `page_count` bounds the child links. Throws CorruptionError naming the
// page, VersionError for an unknown page format.
tree::PagePtr decode_page(std::span<const uint8_t> bytes, const PageLocation& where,
                          uint32_t expected_version, const PayloadCodec& codec,
                          uint32_t page_count);

}  // namespace pbgi::storage
