// libFuzzer target: the page reader on corrupt pages. Each input is tried
// twice: as read from disk (almost always stopped by the checksum), and
// re-sealed with a correct checksum and page id so that the structural
// checks behind the checksum (header, sizes, shapes, links, payloads) see
// the corruption too. Also the manifest, raw and re-framed. Everything must
// end in CorruptionError / VersionError, never a crash or a wild read.
#include "common/errors.h"
#include "storage/codecs/payload_codec.h"
#include "storage/format/byte_order.h"
#include "storage/format/manifest_frame.h"
#include "storage/format/page_frame.h"
#include "storage/pages/manifest_file.h"
#include "storage/pages/page_encoding.h"

#include <cstddef>
#include <cstdint>
#include <vector>

namespace {

void decode(std::span<const uint8_t> bytes, uint32_t page_id) {
  using namespace pbgi::storage;
  uint32_t codec_id = 0;
  // The manifest's leaf format is taken from the page's own flag, so that
  // both surfel record formats are reached.
  LeafFormat leaf_format = LeafFormat::kRelative;
  // The page format too (V4/V6/V8/V10 derived payloads, V5/V7/V9/V11
  // every node's payload stored; V6-V11 compact records with an emission
  // section; V8-V11 the compact header and leaf records; V10/V11 the small
  // frame and surfel section), so that every layout's checks are reached.
  uint32_t version = kPageFormatCurrent;
  if (bytes.size() >= kPageVersionPrefixBytes) {
    const uint32_t v = load_le<uint16_t>(bytes.data() + 4);
    if (is_known_page_format(v)) version = v;
    // read_page_header reads the header of the version the bytes name
    // (32 bytes for one it does not know), not of the one chosen above.
    if (bytes.size() >= page_header_bytes(v)) {
      const PageHeader h = read_page_header(bytes.data());
      if (is_known_payload_codec(h.codec) && !codec_needs_state(h.codec)) codec_id = h.codec;
      if (h.flags & kPageFlagHalfLeaves) leaf_format = LeafFormat::kHalf;
    }
  }
  static const auto codec0 = make_payload_codec(0);
  const auto codec = codec_id == 0 ? codec0 : make_payload_codec(codec_id);
  try {
    const auto page = decode_page(bytes, {"fuzz.pbgp", page_id, 0}, version, *codec,
                                  page_id + 1024, false, leaf_format);
    (void)page;
  } catch (const pbgi::Error&) {
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace pbgi::storage;
  const std::span<const uint8_t> input(data, size);
  // V10/V11 headers hold no page id: the checksum is seeded with it. The
  // corpus's small-frame pages are read as page kSmallFrameId.
  constexpr uint32_t kSmallFrameId = 13;
  const uint32_t v = size >= kPageVersionPrefixBytes ? load_le<uint16_t>(data + 4) : 0;
  const bool small = page_format_has_small_frame(v);
  // 1. As stored.
  decode(input, small ? kSmallFrameId : size >= 12 ? load_le<uint32_t>(data + 8) : 0);
  // 2. Re-sealed: the page id the header names (V4-V9), the size it has
  // (V4-V7 headers store it), a valid checksum.
  if (small ? size >= kMinPageFrameBytes : size >= kCompactPageHeaderBytes + kPageTrailerBytes) {
    std::vector<uint8_t> page(data, data + size);
    uint32_t id = kSmallFrameId;
    if (!small) {
      id = load_le<uint32_t>(page.data() + 8) % 4096;
      store_le<uint32_t>(page.data() + 8, id);
    }
    if (!page_format_has_compact_frame(v) && size >= kPageHeaderBytes + kPageTrailerBytes) {
      store_le<uint32_t>(page.data() + 24, static_cast<uint32_t>(page.size()));
    }
    seal_page(page, id);
    decode(page, id);
  }
  // 3. The same bytes as a manifest, raw and as a re-framed body.
  try {
    (void)decode_manifest(input, "fuzz.pbgm");
  } catch (const pbgi::Error&) {
  }
  try {
    (void)decode_manifest(frame_manifest(input), "fuzz.pbgm");
  } catch (const pbgi::Error&) {
  }
  return 0;
}
