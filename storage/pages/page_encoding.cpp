#include "storage/pages/page_encoding.h"

#include "common/errors.h"
#include "storage/codecs/glossy_pages.h"
#include "storage/format/byte_order.h"
#include "storage/pages/leaf_section.h"
#include "storage/pages/surfel_section.h"
#include "storage/tree/page_records.h"
#include "storage/tree/payload_rounding.h"
#include "storage/tree/scratch_arrays.h"

#include <cstddef>
#include <limits>
#include <string>
#include <vector>

namespace pbgi::storage {

// The builder sizes pages with V4-V7 records (streaming_tree_builder.h:
// 18 bytes a leaf, 40 + 76 a link, a 32-byte header and 3 bytes of
// padding); V8/V9 pages never take more, so no page exceeds page_size:
// a leaf section takes at most 3 + 13 bytes for its first leaf and 15
// for each other, a link 26 + 88 bytes, the header 18.
static_assert(kCompactLinkRecordBytes + tree::kMaxCompactPayloadBytes <= kLinkRecordBytes + tree::kRoundedPayloadBytes);
static_assert(kCompactPageHeaderBytes + 4 <= kPageHeaderBytes);

namespace {
// Leaf records start at a multiple of 4 from the page start.
size_t padded(size_t n) { return (n + 3) & ~size_t(3); }
}  // namespace

void encode_page(const tree::Treelet& t, uint32_t page_id, const PayloadCodec& codec,
                 std::vector<uint8_t>& out, std::span<const uint8_t> glossy) {
  const size_t n = t.shapes.size();
  const bool node_payloads = !t.nodes.empty();
  if (node_payloads && t.nodes.size() != n) {
    throw Error("internal: treelet of " + std::to_string(n) + " nodes has " + std::to_string(t.nodes.size()) +
                " stored payloads");
  }
  // Treelets of 24-byte relative records (only tests make them now) are
  // V4/V5 pages; this build writes every other treelet as V8/V9.
  const bool legacy = t.records == SurfelRecords::kRelative;
  const uint32_t version = legacy ? (node_payloads ? kPageFormatV5 : kPageFormatV4)
                                  : (node_payloads ? kPageFormatNodePayloads : kPageFormatCurrent);
  const bool compact_frame = page_format_has_compact_frame(version);
  const size_t header_bytes = page_header_bytes(version);
  // V4-V7: a shape byte per node, leaf records at a multiple of 4; V8/V9:
  // two shapes a byte (node 2i in the low nibble), no alignment.
  const size_t shape_bytes = compact_frame ? (n + 1) / 2 : n;
  const size_t leaves_at = compact_frame ? header_bytes + shape_bytes : padded(header_bytes + n);
  out.assign(leaves_at, 0);
  if (compact_frame) {
    for (size_t i = 0; i < n; ++i) out[header_bytes + i / 2] |= uint8_t(t.shapes[i] << (4 * (i % 2)));
  } else {
    std::copy(t.shapes.begin(), t.shapes.end(), out.begin() + std::ptrdiff_t(header_bytes));
  }
  // The builder's frames are rounded (leaf_quantizer.h): the leaf
  // section holds them exactly.
  std::vector<LeafRecord> leaves(compact_frame ? t.leaf_records.size() / kLeafRecordBytes : 0);
  for (size_t i = 0; i < leaves.size(); ++i) {
    read_leaf_record(t.leaf_records.data() + i * kLeafRecordBytes, leaves[i].frame, leaves[i].surfel_count);
  }
  if (compact_frame) {
    encode_leaf_section(leaves, out);
  } else {
    out.insert(out.end(), t.leaf_records.begin(), t.leaf_records.end());
  }
  size_t at = out.size();
  const size_t link_record_bytes = compact_frame ? kCompactLinkRecordBytes : kLinkRecordBytes;
  out.resize(at + t.links.size() * link_record_bytes);
  std::vector<tree::Node> linked;
  linked.reserve(t.links.size());
  for (const tree::TreeletLink& l : t.links) {
    if (compact_frame) {
      write_compact_link_record(l.page, l.summary, out.data() + at);  // the tree's bounds are rounded
    } else {
      write_link_record(l.page, l.summary, out.data() + at);
    }
    at += link_record_bytes;
    linked.push_back(l.summary);
  }
  const size_t payload_at = out.size();
  // V5/V7/V9: every node's payload, pre-order; V4: the linked children's,
  // by the codec; V6/V8: the linked children's rounded payloads.
  if (node_payloads) {
    codec.encode(t.nodes, out);
  } else if (compact_frame) {
    for (const tree::Node& l : linked) tree::write_compact_payload(l, out);
  } else if (page_format_rounds_payloads(version)) {
    out.resize(payload_at + linked.size() * tree::kRoundedPayloadBytes);
    for (size_t i = 0; i < linked.size(); ++i) {
      tree::write_rounded_payload(linked[i], out.data() + payload_at + i * tree::kRoundedPayloadBytes);
    }
  } else {
    codec.encode(linked, out);
  }
  const size_t payload_bytes = out.size() - payload_at;
  // Compact records that all hold one albedo: stored once, records
  // without it (kPageFlagSharedAlbedo).
  const size_t surfels = t.surfel_count();
  // V8/V9: compact records as a column-packed surfel section.
  const bool surfel_section = compact_frame && t.records == SurfelRecords::kCompact;
  bool shared_albedo = !surfel_section && t.records == SurfelRecords::kCompact && surfels > 0;
  for (size_t k = 1; shared_albedo && k < surfels; ++k) {
    shared_albedo = compact_record_albedo(t.surfel_records.data() + k * kCompactSurfelRecordBytes) ==
                    compact_record_albedo(t.surfel_records.data());
  }
  if (shared_albedo) {
    const size_t albedo_at = out.size();
    out.resize(albedo_at + 4 + surfels * kCompactSharedAlbedoRecordBytes);
    store_le<uint32_t>(out.data() + albedo_at, compact_record_albedo(t.surfel_records.data()));
    for (size_t k = 0; k < surfels; ++k) {
      drop_albedo(t.surfel_records.data() + k * kCompactSurfelRecordBytes,
                  out.data() + albedo_at + 4 + k * kCompactSharedAlbedoRecordBytes);
    }
  } else if (surfel_section) {
    encode_surfel_section(t.surfel_records, leaves, version, out);
  } else {
    out.insert(out.end(), t.surfel_records.begin(), t.surfel_records.end());
  }
  out.insert(out.end(), t.emission.begin(), t.emission.end());
  out.insert(out.end(), glossy.begin(), glossy.end());
  out.resize(out.size() + page_trailer_bytes(version));

  PageHeader h;
  h.format_version = static_cast<uint16_t>(version);
  h.flags = (node_payloads ? kPageFlagNodePayloads : 0u) | (glossy.empty() ? 0u : kPageFlagGlossy) |
            (t.records == SurfelRecords::kHalf ? kPageFlagHalfLeaves : 0u) |
            (shared_albedo ? kPageFlagSharedAlbedo : 0u);
  h.codec = static_cast<uint16_t>(codec.id());
  h.page_id = page_id;
  h.node_count = static_cast<uint32_t>(n);
  h.surfel_count = static_cast<uint32_t>(t.surfel_count());
  h.payload_bytes = static_cast<uint32_t>(payload_bytes);
  h.page_bytes = static_cast<uint32_t>(out.size());
  write_page_header(h, out.data());
  seal_page(out, page_id);
}

namespace {

// The arrays decode_page() fills and drops for every page, kept per thread
// between calls (storage/tree/scratch_arrays.h).
struct DecodeScratch {
  std::vector<uint8_t> unpacked, unpacked_records;
  std::vector<LeafRecord> leaf_section;
  std::vector<tree::Node> compact_payloads, linked, stored;
  std::vector<tree::TreeletLink> link;

  void trim() {
    tree::trim_scratch(unpacked);
    tree::trim_scratch(unpacked_records);
    tree::trim_scratch(leaf_section);
    tree::trim_scratch(compact_payloads);
    tree::trim_scratch(linked);
    tree::trim_scratch(stored);
    tree::trim_scratch(link);
  }
};

}  // namespace

std::shared_ptr<tree::Page> decode_page(std::span<const uint8_t> bytes, const PageLocation& where,
                                        uint32_t expected_version, const PayloadCodec& codec, uint32_t page_count,
                                        bool glossy_allowed, LeafFormat leaf_format, PageParts* parts) {
  auto page = std::make_shared<tree::Page>();
  decode_page_into(bytes, where, expected_version, codec, page_count, glossy_allowed, leaf_format, parts, *page);
  return page;
}

void decode_page_into(std::span<const uint8_t> bytes, const PageLocation& where, uint32_t expected_version,
                      const PayloadCodec& codec, uint32_t page_count, bool glossy_allowed, LeafFormat leaf_format,
                      PageParts* parts, tree::Page& out) {
  out.glossy.reset();
  out.glossy_bytes = 0;
  PageHeader h = open_page(bytes, where, expected_version);
  const std::string at = where.describe();
  auto corrupt = [&](const std::string& msg) { return CorruptionError(at + ": " + msg); };
  thread_local DecodeScratch scratch;
  struct Trim {
    DecodeScratch& s;
    ~Trim() { s.trim(); }
  } trim{scratch};

  // V10/V11 headers leave the codec to the manifest.
  if (!page_format_has_small_frame(h.format_version) && h.codec != codec.id()) {
    throw corrupt("payload codec " + std::to_string(h.codec) + " differs from the manifest's " +
                  std::to_string(codec.id()));
  }
  // kPageFlagNodePayloads is set exactly in V5/V7 pages, kPageFlagHalfLeaves
  // exactly when the manifest's leaf format is half (a page flagged
  // otherwise is refused); kPageFlagGlossy only where the manifest declares
  // glossy radiance, kPageFlagSharedAlbedo only over compact records
  // (format_version.h).
  const uint32_t want_flags = (page_format_stores_node_payloads(h.format_version) ? kPageFlagNodePayloads : 0u) |
                              (leaf_format == LeafFormat::kHalf ? kPageFlagHalfLeaves : 0u);
  SurfelRecords records = surfel_records_of(leaf_format, page_format_has_compact_records(h.format_version));
  const bool glossy = glossy_allowed && (h.flags & kPageFlagGlossy) != 0;
  // A shared albedo only over compact records in V6/V7 pages (V8/V9 pages
  // store compact records in a surfel section, which needs no flag).
  const bool surfel_section = page_format_has_compact_frame(h.format_version) && records == SurfelRecords::kCompact;
  const bool shared_albedo =
      !surfel_section && records == SurfelRecords::kCompact && (h.flags & kPageFlagSharedAlbedo) != 0;
  if (shared_albedo) records = SurfelRecords::kCompactSharedAlbedo;
  const size_t record_bytes = surfel_record_bytes(records);
  if ((h.flags & ~(glossy ? kPageFlagGlossy : 0u) & ~(shared_albedo ? kPageFlagSharedAlbedo : 0u)) != want_flags) {
    throw corrupt("header flags are " + std::to_string(h.flags) + ", page format " +
                  std::to_string(h.format_version) + " needs " + std::to_string(want_flags));
  }
  const bool node_payloads = (h.flags & kPageFlagNodePayloads) != 0;
  if (h.node_count == 0) throw corrupt("page has no nodes");
  const bool compact_frame = page_format_has_compact_frame(h.format_version);
  const size_t header_bytes = page_header_bytes(h.format_version);
  const size_t trailer_bytes = page_trailer_bytes(h.format_version);
  // 1. Sizes. Leaf and link counts follow from the shapes (each byte is
  //    checked when the treelet is parsed).
  const uint64_t body = bytes.size() - header_bytes - trailer_bytes;
  const uint64_t shape_bytes = compact_frame ? (uint64_t(h.node_count) + 1) / 2 : h.node_count;
  if (shape_bytes > body) {
    throw corrupt(std::to_string(h.node_count) + " shapes do not fit the page");
  }
  // V8/V9 shapes are nibbles: unpacked, one byte a node, for the parse.
  std::vector<uint8_t>& unpacked = scratch.unpacked;
  std::span<const uint8_t> shapes;
  if (!compact_frame) {
    shapes = bytes.subspan(header_bytes, h.node_count);
  } else {
    unpacked.resize(h.node_count);
    for (uint32_t i = 0; i < h.node_count; ++i) unpacked[i] = (bytes[header_bytes + i / 2] >> (4 * (i % 2))) & 15u;
    if (h.node_count % 2 == 1 && (bytes[header_bytes + h.node_count / 2] >> 4) != 0) {
      throw corrupt("the shapes' padding nibble is not zero");
    }
    shapes = unpacked;
  }
  uint64_t leaves = 0, links = 0;
  for (uint8_t s : shapes) {
    leaves += (s & 3u) == 0 ? 1 : 0;
    links += ((s >> 2) & 1u) + ((s >> 3) & 1u);
  }
  const uint64_t leaves_at = compact_frame ? header_bytes + shape_bytes : padded(header_bytes + h.node_count);
  const size_t link_record_bytes = compact_frame ? kCompactLinkRecordBytes : kLinkRecordBytes;
  // V8/V9: the leaf section, decoded first (its size depends on its widths).
  std::vector<LeafRecord>& leaf_section = scratch.leaf_section;
  leaf_section.clear();
  const uint64_t leaf_bytes =
      compact_frame ? decode_leaf_section(bytes.subspan(leaves_at, bytes.size() - trailer_bytes - leaves_at), leaves,
                                          leaf_section, at)
                    : leaves * kLeafRecordBytes;
  const uint64_t links_at = leaves_at + leaf_bytes;
  const uint64_t payload_at = links_at + links * link_record_bytes;
  std::vector<tree::Node>& compact_payloads = scratch.compact_payloads;
  compact_payloads.clear();
  if (compact_frame) {
    // V8/V9 headers do not store the surfel count (the leaves' counts add
    // up to it) nor, in V8, the payload array's size (its compact payloads
    // say theirs).
    if (payload_at + trailer_bytes > bytes.size()) {
      throw corrupt("header, shapes and leaves (" + std::to_string(h.node_count) + " nodes, " + std::to_string(leaves) +
                    " leaves, " + std::to_string(links) + " links) need at least " +
                    std::to_string(payload_at + trailer_bytes) + " bytes, page has " + std::to_string(bytes.size()));
    }
    uint64_t surfels = 0;
    for (const LeafRecord& l : leaf_section) surfels += l.surfel_count;
    if (surfels > std::numeric_limits<uint32_t>::max()) {
      throw corrupt("leaf records count " + std::to_string(surfels) + " surfels");
    }
    h.surfel_count = uint32_t(surfels);
    if (!node_payloads) {
      // V8: the linked children's compact payloads, back to back.
      compact_payloads.assign(links, tree::Node{});
      uint64_t used = 0;
      const auto rest = bytes.subspan(payload_at, bytes.size() - trailer_bytes - payload_at);
      for (uint64_t i = 0; i < links; ++i) {
        const size_t n = tree::read_compact_payload(rest.subspan(used), compact_payloads[i]);
        if (n == 0) {
          throw corrupt("link " + std::to_string(i) + "'s payload is cut short or holds what no writer produces");
        }
        used += n;
      }
      h.payload_bytes = uint32_t(used);
    }
  }
  const uint64_t albedo_at = payload_at + h.payload_bytes;
  const uint64_t surfels_at = albedo_at + (shared_albedo ? 4 : 0);
  // V8/V9 compact records: decoded from the surfel section (its size
  // follows from its column widths) into `unpacked_records`.
  std::vector<uint8_t>& unpacked_records = scratch.unpacked_records;
  std::span<const uint8_t> record_span;
  uint64_t surfel_bytes = uint64_t(h.surfel_count) * record_bytes;
  if (surfel_section) {
    if (surfels_at + trailer_bytes > bytes.size()) {
      throw corrupt("the payload array (" + std::to_string(h.payload_bytes) + " bytes) runs past the page");
    }
    surfel_bytes = decode_surfel_section(bytes.subspan(surfels_at, bytes.size() - trailer_bytes - surfels_at),
                                         leaf_section, h.format_version, unpacked_records, at);
    record_span = unpacked_records;
  }
  const uint64_t emission_at = surfels_at + surfel_bytes;
  if (!surfel_section && emission_at + trailer_bytes <= bytes.size()) {
    record_span = bytes.subspan(surfels_at, surfel_bytes);
  }
  // Compact records: one emission entry per record that emits (counted
  // once the records are known to lie inside the page).
  uint64_t emitting = 0;
  if (emission_out_of_line(records) && record_span.size() == uint64_t(h.surfel_count) * record_bytes) {
    for (uint64_t k = 0; k < h.surfel_count; ++k) {
      emitting += surfel_record_emits(records, record_span.data() + k * record_bytes) ? 1 : 0;
    }
  }
  const uint64_t glossy_at = emission_at + emitting * kEmissionEntryBytes;
  const uint64_t need = glossy_at + trailer_bytes;
  if (parts) {
    *parts = {header_bytes, leaves_at, links_at,
              payload_at,   albedo_at, surfels_at,
              emission_at,  glossy_at, bytes.size() - trailer_bytes};
  }
  // A glossy section fills what lies between the surfels and the trailer.
  if (glossy ? need >= bytes.size() : need != bytes.size()) {
    throw corrupt("header and shapes (" + std::to_string(h.node_count) + " nodes, " + std::to_string(leaves) +
                  " leaves, " + std::to_string(links) + " links, " + std::to_string(h.payload_bytes) +
                  " payload bytes, " + std::to_string(h.surfel_count) + " surfels, " + std::to_string(emitting) +
                  " emitting) need " + std::to_string(need) + " bytes, page has " + std::to_string(bytes.size()));
  }

  // 2. Links and the payloads: the linked children's (V2) or every
  //    node's (V3).
  std::vector<tree::TreeletLink>& link = scratch.link;
  std::vector<tree::Node>& linked = scratch.linked;
  link.assign(links, tree::TreeletLink{});
  linked.assign(links, tree::Node{});
  for (uint64_t i = 0; i < links; ++i) {
    const uint8_t* record = bytes.data() + links_at + i * link_record_bytes;
    if (!compact_frame) {
      read_link_record(record, link[i].page, linked[i]);
    } else if (!read_compact_link_record(record, link[i].page, linked[i])) {
      throw corrupt("link record " + std::to_string(i) + " has a sphere, cone or area out of range");
    }
    if (link[i].page >= page_count) {
      throw corrupt("link " + std::to_string(i) + " to page " + std::to_string(link[i].page) +
                    " outside the " + std::to_string(page_count) + " pages");
    }
  }
  std::vector<tree::Node>& stored = scratch.stored;
  stored.clear();
  const bool rounded = page_format_rounds_payloads(h.format_version);
  if (node_payloads) {
    stored.assign(h.node_count, tree::Node{});
    codec.decode(bytes.subspan(payload_at, h.payload_bytes), stored, at);
  } else if (compact_frame) {
    for (uint64_t i = 0; i < links; ++i) {
      linked[i].radiance_sh = compact_payloads[i].radiance_sh;
      linked[i].coverage_sh = compact_payloads[i].coverage_sh;
    }
  } else if (rounded) {
    if (h.payload_bytes != links * tree::kRoundedPayloadBytes) {
      throw corrupt("payload array of " + std::to_string(h.payload_bytes) + " bytes for " + std::to_string(links) +
                    " links of " + std::to_string(tree::kRoundedPayloadBytes) + " bytes");
    }
    for (uint64_t i = 0; i < links; ++i) {
      if (!tree::read_rounded_payload(bytes.data() + payload_at + i * tree::kRoundedPayloadBytes, linked[i])) {
        throw corrupt("link " + std::to_string(i) + "'s payload has an exponent out of range");
      }
    }
  } else {
    codec.decode(bytes.subspan(payload_at, h.payload_bytes), linked, at);
  }
  for (uint64_t i = 0; i < links; ++i) link[i].summary = linked[i];

  // 3. The treelet, every summary derived.
  tree::TreeletView view;
  view.shapes = shapes;
  if (compact_frame) {
    view.leaves = leaf_section;
  } else {
    view.leaf_records = bytes.subspan(leaves_at, leaves * kLeafRecordBytes);
  }
  view.links = link;
  view.surfel_records = record_span;
  view.records = records;
  if (shared_albedo) view.shared_albedo = load_le<uint32_t>(bytes.data() + albedo_at);
  view.emission = bytes.subspan(emission_at, emitting * kEmissionEntryBytes);
  view.payloads = stored;
  view.max_levels = kMaxPageLevels;
  view.rounded_payloads = rounded;
  view.rounded_bounds = compact_frame;
  tree::expand_treelet(view, h.page_id, at, out);
  // Link records carry a linked child's exact summary only when its
  // payload is stored with it (derived payloads) and no glossy radiance is
  // shown that the record lacks: otherwise a reader must load the child.
  if (node_payloads || glossy) std::vector<tree::PageLink>().swap(out.links);  // freed, not only emptied
  if (glossy) {
    std::vector<float> link_areas(links);
    for (uint64_t i = 0; i < links; ++i) link_areas[i] = link[i].summary.area;
    const auto section = bytes.subspan(glossy_at, bytes.size() - need);
    out.glossy = GlossyNodes::decode(section, out, link_areas, at);
    out.glossy_bytes = out.glossy->memory_bytes();
  }
}

}  // namespace pbgi::storage
