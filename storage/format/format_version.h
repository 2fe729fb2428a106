// Magic numbers and named format versions of everything pbgi stores on disk.
// Every layout change gets a new named constant; readers branch on the
// version they find and refuse the ones they do not know (VersionError).
// The byte layouts are specified in storage/format/FORMAT.md.
#pragma once

#include <cstdint>

namespace pbgi::storage {

// A four-character code stored as a little-endian u32, so the file shows the
// letters in order ("PBGP" reads as 'P','B','G','P' in a hex dump).
constexpr uint32_t fourcc(const char (&s)[5]) {
  return uint32_t(uint8_t(s[0])) | uint32_t(uint8_t(s[1])) << 8 |
         uint32_t(uint8_t(s[2])) << 16 | uint32_t(uint8_t(s[3])) << 24;
}

inline constexpr uint32_t kPageMagic = fourcc("PBGP");      // each page of pages.pbgp
inline constexpr uint32_t kManifestMagic = fourcc("PBGM");  // manifest.pbgm
inline constexpr uint32_t kSceneEntryMagic = fourcc("PBGS");  // <cache>/ingested/<key>.pbgiscene

// Page layout versions.
//   V1 (retired, refused): 32-byte header, topology array (64 B/node),
//       payload array (codec), surfel array (64 B/surfel, float32), trailer.
//   V2 (retired, refused): 32-byte header, shape bytes (1 B/node), leaf
//       frames, link records, payload array (codec, page-boundary nodes
//       only), quantized surfel records (24 B/surfel), 8-byte XXH3-64
//       trailer. Bounds, cones, areas and payloads of the nodes inside a
//       page are derived when it loads. Treelets as large as a page allows
//       (~1000 nodes, ~10 levels), 4 KiB-aligned.
//   V3 (retired, refused): the V2 layout; header flag kPageFlagNodePayloads
//       says the payload array holds every node's payload (pre-order).
//   V4: the V2 byte layout over cut-shaped treelets: a page holds at most
//       kMaxPageLevels levels of the tree (and page_size bytes), pages are
//       packed without alignment. A gather's cut then leaves a page after
//       a few levels instead of deriving a thousand nodes it never reads,
//       and decides on a linked child from its link record (exact summary
//       and payload) without loading the child's page. Derived payloads.
//   V5: V4 with the V3 payload array (kPageFlagNodePayloads: every node's
//       payload stored); written by builds that store node payloads
//       (payload_codec float32-sh, kmeans-sh).
//   V6: V4 with compact surfel records (leaf format relative: 18 bytes
//       instead of 24, emission out of line in an emission section after
//       the surfel records, storage/tree/page_records.h) and rounded node
//       payloads (storage/tree/payload_rounding.h), which the links store
//       in 76 bytes. Derived payloads.
//   V7: V5 (every node's payload stored) with V6's compact records.
//   V8: V6's treelet in a compact page frame (FORMAT.md "Page formats V8
//       and V9"): a 14-byte header (what the page table, the shapes or the
//       sections give is gone: page_bytes, surfel_count, payload_bytes;
//       narrower node count, codec and flags), shapes two a byte, a
//       bit-packed leaf section, 26-byte link records, compact link
//       payloads, a column-packed surfel section. The tree's node bounds
//       and leaf frames are rounded (bounds_rounding.h, page_records.h
//       RoundedFrame), as V6's payloads were, so links and leaves store
//       them exactly. Derived payloads. Always with a V5 manifest.
//   V9: V8 with every node's payload stored (V7's payload array, its size
//       in a u32 after the header).
//   V10: V8 in a smaller frame and section (FORMAT.md "Page formats V10
//       and V11"): a 9-byte header (no codec, no page id) and a 4-byte
//       trailer whose checksum is seeded with the page id; surfel
//       positions on a grid of 10 bits of the leaf frame (14 before),
//       stored in 10 bits; radius codes stored as the difference to the
//       previous surfel's radius in this surfel's leaf frame. ~3 bytes
//       a surfel fewer than V8. Derived payloads.
//   V11: V10 with every node's payload stored (as V9).
inline constexpr uint32_t kPageFormatV1 = 1;
inline constexpr uint32_t kPageFormatV2 = 2;
inline constexpr uint32_t kPageFormatV3 = 3;
inline constexpr uint32_t kPageFormatV4 = 4;
inline constexpr uint32_t kPageFormatV5 = 5;
inline constexpr uint32_t kPageFormatV6 = 6;
inline constexpr uint32_t kPageFormatV7 = 7;
inline constexpr uint32_t kPageFormatV8 = 8;
inline constexpr uint32_t kPageFormatV9 = 9;
inline constexpr uint32_t kPageFormatV10 = 10;
inline constexpr uint32_t kPageFormatV11 = 11;
// What this build writes: derived payloads, and every node's payload stored.
inline constexpr uint32_t kPageFormatCurrent = kPageFormatV10;  // derived payloads
inline constexpr uint32_t kPageFormatNodePayloads = kPageFormatV11;

// Most levels of the tree one V4/V5 page may hold (root to deepest leaf of
// its treelet, counted in nodes). Readers check it; the build chooses fewer
// (tree::BuildOptions::page_levels and upper_page_levels, docs/out-of-core.md
// "Page levels").
inline constexpr uint32_t kMaxPageLevels = 16;

// Page header flags. kPageFlagNodePayloads: V3 pages, always. kPageFlagGlossy
// (V2 or V3 pages of a V3 manifest that declares glossy radiance): the page
// ends, before its trailer, with a glossy radiance section (a serialized
// wavelet tree code, storage/codecs/glossy_pages.h, itself versioned and
// checksummed) instead of ending at its surfel records.
// kPageFlagHalfLeaves (pages of a V4 manifest whose leaf_format is half):
// the surfel records are 38-byte half-float records instead of 24-byte
// frame-relative ones (storage/tree/page_records.h). The flag and the
// manifest must agree, so a page is never decoded with the wrong stride.
inline constexpr uint32_t kPageFlagNodePayloads = 1u << 0;
inline constexpr uint32_t kPageFlagGlossy = 1u << 1;
inline constexpr uint32_t kPageFlagHalfLeaves = 1u << 2;
// kPageFlagSharedAlbedo (V6/V7 pages of compact records only): every
// surfel of the page has the same albedo, stored once (a u32 RGB9E5 after
// the payload array), and the records are 14 bytes, without it.
inline constexpr uint32_t kPageFlagSharedAlbedo = 1u << 3;

// Manifest layout versions.
//   V1: 16-byte header, body (options, stats, root, codec, page table),
//       8-byte XXH3-64 trailer.
//   V2: V1 + payload storage (derived / every node), the codec's state (the
//       kmeans-sh LUT, itself versioned and checksummed) and the payload
//       build options (payload_codec, lut_entries, lut_sample_fraction).
//   V3: V2 + glossy radiance storage (cube_resolution, wavelet_threshold;
//       cube_resolution 0 = none, and then pages never carry the glossy
//       flag). Written only when the page set stores glossy radiance, so
//       diffuse page sets stay V2 and readable by older builds.
//   V4: V3 (cube_resolution may be 0 here) + leaf_format (u32: 0 relative,
//       1 half). Written only for leaf formats other than relative, so
//       default page sets keep V2/V3 and stay readable by older builds.
inline constexpr uint32_t kManifestFormatV1 = 1;
inline constexpr uint32_t kManifestFormatV2 = 2;
inline constexpr uint32_t kManifestFormatV3 = 3;
//   V5: V4's fields (glossy_resolution may be 0, leaf_format 0 or 1), the
//       page table as the pages' sizes alone, LEB128 varints: pages follow
//       each other from offset 0 without gaps, so the offsets are the
//       sizes' prefix sums (2 bytes a page instead of 12). Written with
//       V8/V9 pages, and only with them.
//   V6: V5 + air regions (storage/tree/region_grid.h): the region grid
//       (origin, voxel size, dimensions, region count, runs along x as
//       varint pairs) and each region's subtree root. Written only when
//       the tree keeps regions apart, so other page sets stay V5.
inline constexpr uint32_t kManifestFormatV4 = 4;
inline constexpr uint32_t kManifestFormatV5 = 5;
inline constexpr uint32_t kManifestFormatV6 = 6;
inline constexpr uint32_t kManifestFormatCurrent = kManifestFormatV6;  // what this build writes
inline constexpr uint32_t kManifestFormatLatest = kManifestFormatV6;   // the newest this build reads

// Version of a page set as a whole (manifest + pages + codec set). Build keys
// hash it, so bumping it makes every daemon rebuild its cached page sets.
//   1: V1 pages, trees split at the median of the largest axis.
//   2: V2 pages, trees over Morton order (storage/tree/streaming_tree_builder.h).
//   3: glossy senders: surfels of glossy materials carry a specular lobe
//      and pages may carry glossy radiance (V3 manifest, kPageFlagGlossy).
//   4: V4/V5 pages: treelets of at most 4 levels by default
//      (BuildOptions::page_levels, upper_page_levels; other values enter
//      the build key), unaligned.
//   5: V6/V7 pages: compact (18-byte) surfel records, emission section,
//      shared albedo, rounded node payloads (76-byte link payloads).
//   6: V8/V9 pages (rounded node bounds and leaf frames, compact page
//      frame) and V5 manifests (page sizes).
//   7: air regions: a scene whose empty space falls apart into closed
//      regions keeps each region's surfels in a subtree of its own (V6
//      manifest); the pages are unchanged.
//   8: V10/V11 pages: a smaller frame, surfel positions on a 10-bit grid of
//      the leaf frame, radius codes stored against a prediction.
inline constexpr uint32_t kPageSetFormatVersion = 8;

// Ingested-scene entry versions (server/ingest/scene_entry.h).
//   1-3 (refused): no frame -- the bare SceneChunk stream, dependencies in a
//       .deps sidecar, nothing checksummed. Their keys differ (the version
//       is hashed into them), so they are never looked up; a file of that
//       kind under a current key fails the magic.
//   V4 (refused): 32-byte head (magic, version, dependency and body sizes,
//       body checksum), the dependency lines, the head's XXH3-64, then the
//       SceneChunk stream whose XXH3-64 the head holds.
//   V5: V4's frame; the body's SceneHeader carries SceneSize (the decoded
//       geometry's counts), so that a reopened scene is charged to the
//       memory budget and its arrays sized before its first chunk. V4
//       entries are keyed apart (never looked up) and refused by version.
inline constexpr uint32_t kSceneEntryFormatV4 = 4;
inline constexpr uint32_t kSceneEntryFormatV5 = 5;
constexpr bool is_known_scene_entry_format(uint32_t v) { return v == kSceneEntryFormatV5; }

// V1-V3 pages are no longer read: their page sets were built by
// kPageSetFormatVersion 3 or older and are rebuilt (the build key changed),
// so such a page or manifest is a VersionError.
// V4/V5 pages (kPageSetFormatVersion 4) are still read: their build keys
// no longer match, so a daemon rebuilds them, but a page set opened by
// path (pbgi inspect, benchmarks) reads as before.
// V6/V7 pages (kPageSetFormatVersion 5) likewise.
// V8/V9 pages (kPageSetFormatVersion 6, 7) likewise.
constexpr bool is_known_page_format(uint32_t v) { return v >= kPageFormatV4 && v <= kPageFormatV11; }
constexpr bool is_retired_page_format(uint32_t v) { return v >= kPageFormatV1 && v <= kPageFormatV3; }
// Whether pages of format `v` store every node's payload.
constexpr bool page_format_stores_node_payloads(uint32_t v) {
  return v == kPageFormatV5 || v == kPageFormatV7 || v == kPageFormatV9 || v == kPageFormatV11;
}
// Whether pages of format `v` hold compact surfel records (leaf format
// relative) and an emission section.
constexpr bool page_format_has_compact_records(uint32_t v) { return v >= kPageFormatV6 && v <= kPageFormatV11; }
// Whether the nodes of pages of format `v` have rounded payloads
// (storage/tree/payload_rounding.h), which derived pages' links store in
// 76 bytes instead of the codec's 144.
constexpr bool page_format_rounds_payloads(uint32_t v) { return v >= kPageFormatV6 && v <= kPageFormatV11; }
// Whether pages of format `v` have the compact frame (14-byte header, no
// padding) and 13-byte leaf records of rounded frames (page_frame.h,
// page_records.h).
constexpr bool page_format_has_compact_frame(uint32_t v) { return v >= kPageFormatV8 && v <= kPageFormatV11; }
// Whether pages of format `v` have the small frame (9-byte header without
// codec and page id, 4-byte trailer of a checksum seeded with the page id)
// and the V10 surfel section (10-bit positions, predicted radius codes).
constexpr bool page_format_has_small_frame(uint32_t v) { return v == kPageFormatV10 || v == kPageFormatV11; }
constexpr bool is_known_manifest_format(uint32_t v) { return v >= kManifestFormatV1 && v <= kManifestFormatV6; }

}  // namespace pbgi::storage
