#include "storage/format/page_frame.h"

#include "common/errors.h"
#include "storage/format/byte_order.h"
#include "storage/format/checksum.h"
#include "storage/format/known_versions.h"

#include <cstdio>

namespace pbgi::storage {

std::string PageLocation::describe() const {
  return file + ": page " + std::to_string(page_id) + " at offset " + std::to_string(offset);
}

void write_page_header(const PageHeader& h, uint8_t* out) {
  if (page_format_has_small_frame(h.format_version)) {
    if (h.node_count > kMaxCompactPageNodes || h.flags > 255) {
      throw Error("internal: page " + std::to_string(h.page_id) + " has " + std::to_string(h.node_count) +
                  " nodes, flags " + std::to_string(h.flags) + ": too many for a small page header");
    }
    store_le<uint32_t>(out + 0, h.magic);
    store_le<uint16_t>(out + 4, h.format_version);
    out[6] = uint8_t(h.flags);
    store_le<uint16_t>(out + 7, uint16_t(h.node_count));
    if (page_format_stores_node_payloads(h.format_version)) store_le<uint32_t>(out + 9, h.payload_bytes);
    return;
  }
  if (page_format_has_compact_frame(h.format_version)) {
    if (h.node_count > kMaxCompactPageNodes || h.codec > 255 || h.flags > 255) {
      throw Error("internal: page " + std::to_string(h.page_id) + " has " + std::to_string(h.node_count) +
                  " nodes, codec " + std::to_string(h.codec) + ", flags " + std::to_string(h.flags) +
                  ": too many for a compact page header");
    }
    store_le<uint32_t>(out + 0, h.magic);
    store_le<uint16_t>(out + 4, h.format_version);
    out[6] = uint8_t(h.codec);
    out[7] = uint8_t(h.flags);
    store_le<uint32_t>(out + 8, h.page_id);
    store_le<uint16_t>(out + 12, uint16_t(h.node_count));
    if (page_format_stores_node_payloads(h.format_version)) store_le<uint32_t>(out + 14, h.payload_bytes);
    return;
  }
  store_le<uint32_t>(out + 0, h.magic);
  store_le<uint16_t>(out + 4, h.format_version);
  store_le<uint16_t>(out + 6, h.codec);
  store_le<uint32_t>(out + 8, h.page_id);
  store_le<uint32_t>(out + 12, h.node_count);
  store_le<uint32_t>(out + 16, h.surfel_count);
  store_le<uint32_t>(out + 20, h.payload_bytes);
  store_le<uint32_t>(out + 24, h.page_bytes);
  store_le<uint32_t>(out + 28, h.flags);
}

PageHeader read_page_header(const uint8_t* in) {
  PageHeader h;
  h.magic = load_le<uint32_t>(in + 0);
  h.format_version = load_le<uint16_t>(in + 4);
  if (page_format_has_small_frame(h.format_version)) {
    h.flags = in[6];
    h.node_count = load_le<uint16_t>(in + 7);
    if (page_format_stores_node_payloads(h.format_version)) h.payload_bytes = load_le<uint32_t>(in + 9);
    return h;
  }
  if (page_format_has_compact_frame(h.format_version)) {
    h.codec = in[6];
    h.flags = in[7];
    h.page_id = load_le<uint32_t>(in + 8);
    h.node_count = load_le<uint16_t>(in + 12);
    if (page_format_stores_node_payloads(h.format_version)) h.payload_bytes = load_le<uint32_t>(in + 14);
    return h;
  }
  h.codec = load_le<uint16_t>(in + 6);
  h.page_id = load_le<uint32_t>(in + 8);
  h.node_count = load_le<uint32_t>(in + 12);
  h.surfel_count = load_le<uint32_t>(in + 16);
  h.payload_bytes = load_le<uint32_t>(in + 20);
  h.page_bytes = load_le<uint32_t>(in + 24);
  h.flags = load_le<uint32_t>(in + 28);
  return h;
}

namespace {
// The trailer's value: V10/V11 the low half of the checksum seeded with the
// page id, older formats the checksum.
uint64_t page_checksum(std::span<const uint8_t> body, uint32_t version, uint32_t page_id) {
  if (page_format_has_small_frame(version)) return checksum64(body.data(), body.size(), page_id) & 0xffffffffu;
  return checksum64(body.data(), body.size());
}
}  // namespace

void seal_page(std::span<uint8_t> page, uint32_t page_id) {
  const uint32_t version = load_le<uint16_t>(page.data() + 4);
  const size_t body = page.size() - page_trailer_bytes(version);
  const uint64_t c = page_checksum(page.first(body), version, page_id);
  if (page_trailer_bytes(version) == 4) {
    store_le<uint32_t>(page.data() + body, uint32_t(c));
  } else {
    store_le<uint64_t>(page.data() + body, c);
  }
}

namespace {
std::string hex32(uint32_t v) {
  char buf[11];
  std::snprintf(buf, sizeof buf, "0x%08x", v);
  return buf;
}
}  // namespace

std::string unsupported_page_format(uint32_t version) {
  const std::string reads = " (reads " + known_versions(is_known_page_format) + ")";
  if (is_retired_page_format(version)) {
    return "page format version " + std::to_string(version) +
           " is retired (treelets not shaped for cuts): rebuild the page set" + reads;
  }
  return "page format version " + std::to_string(version) + " is not supported by this build" + reads;
}

PageHeader open_page(std::span<const uint8_t> page, const PageLocation& where,
                     uint32_t expected_version) {
  const std::string at = where.describe() + " (" + std::to_string(page.size()) + " bytes)";
  // The smallest frame (V10); the version's own header size is checked
  // once the version is known.
  if (page.size() < kMinPageFrameBytes) {
    throw CorruptionError(at + ": too small for a page: expected at least " + std::to_string(kMinPageFrameBytes) +
                          " bytes");
  }
  // The trailer of the format the page names (a damaged version field
  // names another frame, whose checksum then fails); an unknown version,
  // a newer writer's, is checked as V4-V9's so that a sound page of it
  // reports its version below.
  const uint32_t named = load_le<uint16_t>(page.data() + 4);
  const uint32_t frame = is_known_page_format(named) ? named : kPageFormatV8;
  const size_t trailer = page_trailer_bytes(frame);
  const size_t body = page.size() - trailer;
  const uint64_t expected =
      trailer == 4 ? load_le<uint32_t>(page.data() + body) : load_le<uint64_t>(page.data() + body);
  const uint64_t found = page_checksum(page.first(body), frame, where.page_id);
  if (expected != found) {
    throw CorruptionError(at + ": checksum mismatch at trailer offset " +
                          std::to_string(where.offset + body) + ": expected " +
                          checksum_hex(expected) + ", found " + checksum_hex(found));
  }
  const auto magic = load_le<uint32_t>(page.data());
  if (magic != kPageMagic) {
    throw CorruptionError(at + ": bad magic: expected " + hex32(kPageMagic) + " ('PBGP'), found " + hex32(magic));
  }
  const uint32_t version = load_le<uint16_t>(page.data() + 4);
  if (!is_known_page_format(version)) {
    throw VersionError(at + ": " + unsupported_page_format(version));
  }
  if (version != expected_version) {
    throw CorruptionError(at + ": page format version " + std::to_string(version) + " differs from the manifest's " +
                          std::to_string(expected_version));
  }
  if (page.size() < page_header_bytes(version) + trailer) {
    throw CorruptionError(at + ": too small for a page of format " + std::to_string(version) + ": expected at least " +
                          std::to_string(page_header_bytes(version) + trailer) + " bytes");
  }
  PageHeader h = read_page_header(page.data());
  // Compact headers do not store the page's size: the page table's is it;
  // small ones not its id either: the checksum, seeded with it, vouched.
  if (page_format_has_compact_frame(version)) h.page_bytes = uint32_t(page.size());
  if (page_format_has_small_frame(version)) h.page_id = where.page_id;
  if (h.page_id != where.page_id) {
    throw CorruptionError(at + ": header names page " + std::to_string(h.page_id) +
                          ", expected " + std::to_string(where.page_id));
  }
  if (h.page_bytes != page.size()) {
    throw CorruptionError(at + ": header says " + std::to_string(h.page_bytes) +
                          " bytes, the page table " + std::to_string(page.size()));
  }
  return h;
}

}  // namespace pbgi::storage
