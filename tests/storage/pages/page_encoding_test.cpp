// Page bytes of the two surfel record layouts this build reads for leaf
// format relative: compact (V8/V9, written; V6/V7 read) and 24-byte
// relative (V4/V5, read as before); and the checks behind the checksum on
// the compact page frame (V8/V9: 14-byte header, 13-byte leaf records)
// and the emission section of compact pages.
#include "storage/pages/page_encoding.h"
#include "common/errors.h"
#include "storage/codecs/payload_codec.h"
#include "storage/format/byte_order.h"
#include "storage/format/manifest_frame.h"
#include "storage/format/packed_values.h"
#include "storage/pages/leaf_section.h"
#include "storage/pages/manifest_file.h"
#include "storage/pages/surfel_section.h"
#include "storage/tree/leaf_quantizer.h"
#include "storage/tree/morton.h"
#include "storage/tree/payload_rounding.h"
#include "storage/tree/streaming_tree_builder.h"
#include "storage/tree/tree_builder.h"
#include "tests/storage/tree/random_surfels.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

namespace pbgi::storage {
namespace {

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

// A page of one leaf holding `surfels`, in `layout`; `decoded` gets what a
// reader must decode.
tree::Treelet one_leaf(SurfelRecords layout, const std::vector<Surfel>& surfels, std::vector<Surfel>& decoded) {
  tree::Treelet t;
  t.records = layout;
  t.shapes.push_back(encode_shape({}));
  t.surfel_records.resize(surfels.size() * surfel_record_bytes(layout));
  decoded.resize(surfels.size());
  const LeafFrame f = tree::quantize_leaf(layout, surfels, t.surfel_records.data(), decoded, t.emission);
  RoundedFrame rounded;
  EXPECT_TRUE(to_rounded_frame(f, rounded)) << "the build's leaf frames are rounded";
  t.leaf_records.resize(kLeafRecordBytes);
  write_leaf_record(f, uint32_t(surfels.size()), t.leaf_records.data());
  return t;
}

// Four surfels, two of which emit.
std::vector<Surfel> leaf_surfels() {
  std::vector<Surfel> s = test::random_surfels(4, 3);
  s[0].emission = {2.f, 1.f, 0.5f};
  s[1].emission = {0.f, 0.f, 0.f};
  s[2].emission = {0.f, 0.f, 0.f};
  s[3].emission = {0.f, 40.f, 0.f};
  return s;
}

// A treelet's leaves, as a page's leaf section holds them.
std::vector<LeafRecord> leaf_records(const tree::Treelet& t) {
  std::vector<LeafRecord> leaves(t.leaf_records.size() / kLeafRecordBytes);
  for (size_t i = 0; i < leaves.size(); ++i) {
    read_leaf_record(t.leaf_records.data() + i * kLeafRecordBytes, leaves[i].frame, leaves[i].surfel_count);
  }
  return leaves;
}

// The size of the leaf section of a treelet's leaves (V8-V11 pages).
size_t leaf_section_bytes(const tree::Treelet& t) {
  std::vector<uint8_t> out;
  encode_leaf_section(leaf_records(t), out);
  return out.size();
}

// The size of the surfel section of a treelet's compact records (V8/V9).
size_t surfel_section_bytes(const tree::Treelet& t) {
  std::vector<uint8_t> out;
  encode_surfel_section(t.surfel_records, leaf_records(t), kPageFormatCurrent, out);
  return out.size();
}

std::shared_ptr<tree::Page> decode(std::span<const uint8_t> bytes, uint32_t version) {
  static const auto codec = make_payload_codec(0);
  return decode_page(bytes, {"/x/pages.pbgp", 0, 0}, version, *codec, 1);
}

TEST(PageEncoding, CompactAndRelativePagesDecodeWhatTheBuildDecoded) {
  const std::vector<Surfel> surfels = leaf_surfels();
  const auto codec = make_payload_codec(0);
  for (const SurfelRecords layout : {SurfelRecords::kCompact, SurfelRecords::kRelative}) {
    std::vector<Surfel> want;
    const tree::Treelet t = one_leaf(layout, surfels, want);
    EXPECT_EQ(t.emission.size(), layout == SurfelRecords::kCompact ? 2 * kEmissionEntryBytes : 0u);
    std::vector<uint8_t> bytes;
    encode_page(t, 0, *codec, bytes);
    const uint32_t version = layout == SurfelRecords::kCompact ? kPageFormatCurrent : kPageFormatV4;
    EXPECT_EQ(read_page_header(bytes.data()).format_version, version);
    const size_t body =
        layout == SurfelRecords::kCompact
            ? kSmallPageHeaderBytes + 1 /*shape, not padded*/ + leaf_section_bytes(t) + surfel_section_bytes(t)
            : kPageHeaderBytes + 4 /*shape, padded*/ + kLeafRecordBytes + 4 * surfel_record_bytes(layout);
    EXPECT_EQ(bytes.size(), body + t.emission.size() + page_trailer_bytes(version));
    const auto page = decode(bytes, version);
    ASSERT_EQ(page->surfels.size(), surfels.size());
    for (size_t i = 0; i < surfels.size(); ++i) {
      EXPECT_TRUE(test::same_surfel(page->surfels[i], want[i])) << i;
      // Emission is RGB9E5 in both layouts, in the record or out of line.
      EXPECT_EQ(page->surfels[i].emission, decode_rgb9e5(encode_rgb9e5(surfels[i].emission))) << i;
    }
    // A page is read only as the format its manifest declares.
    const uint32_t other = version == kPageFormatCurrent ? kPageFormatV4 : kPageFormatCurrent;
    try {
      decode(bytes, other);
      FAIL() << "page format " << version << " read as " << other;
    } catch (const CorruptionError& e) {
      EXPECT_TRUE(contains(e.what(), "differs from the manifest's")) << e.what();
    }
  }
}

// Compact pages whose surfels share one albedo store it once: in V8 pages
// as albedo columns of width 0 in the surfel section (V6's shared-albedo
// flag is refused there); V4 pages store it in every record.
TEST(PageEncoding, SharedAlbedoIsStoredOnce) {
  std::vector<Surfel> surfels = leaf_surfels();
  std::vector<Surfel> varied = surfels;
  for (Surfel& s : surfels) s.albedo = {0.7f, 0.5f, 0.25f};
  const auto codec = make_payload_codec(0);
  for (const SurfelRecords layout : {SurfelRecords::kCompact, SurfelRecords::kRelative}) {
    std::vector<Surfel> want, unused;
    const tree::Treelet t = one_leaf(layout, surfels, want);
    std::vector<uint8_t> bytes, varied_bytes;
    encode_page(t, 0, *codec, bytes);
    encode_page(one_leaf(layout, varied, unused), 0, *codec, varied_bytes);
    const PageHeader h = read_page_header(bytes.data());
    EXPECT_EQ(h.flags & kPageFlagSharedAlbedo, 0u);
    if (layout == SurfelRecords::kCompact) {
      // 4 surfels of one albedo against 4 of different ones: the 27 bits
      // of mantissas a surfel (less the differences' widths) are gone.
      EXPECT_LE(bytes.size() + 4 * size_t{2}, varied_bytes.size());
    } else {
      EXPECT_EQ(bytes.size(), varied_bytes.size());
    }
    const auto page = decode(bytes, h.format_version);
    ASSERT_EQ(page->surfels.size(), want.size());
    for (size_t i = 0; i < want.size(); ++i) EXPECT_TRUE(test::same_surfel(page->surfels[i], want[i])) << i;
    // The V6 flag on a V8 or a V4 page (re-sealed, as a writer bug would).
    auto bad = bytes;
    PageHeader flipped = h;
    flipped.flags ^= kPageFlagSharedAlbedo;
    write_page_header(flipped, bad.data());
    seal_page(bad);
    try {
      decode(bad, h.format_version);
      FAIL() << "shared albedo flag set on a page of format " << h.format_version;
    } catch (const CorruptionError& e) {
      EXPECT_TRUE(contains(e.what(), "/x/pages.pbgp: page 0")) << e.what();
    }
  }
}

// Damage behind the checksum (a page re-sealed after the damage, as a
// writer bug would seal it): the record's emission flags and the emission
// section must agree, else the page is corrupt, named.
TEST(PageEncoding, EmissionFlagsAndEntriesMustAgree) {
  const auto codec = make_payload_codec(0);
  std::vector<Surfel> want;
  const tree::Treelet t = one_leaf(SurfelRecords::kCompact, leaf_surfels(), want);
  std::vector<uint8_t> good;
  encode_page(t, 0, *codec, good);
  ASSERT_NO_THROW(decode(good, kPageFormatCurrent));
  const size_t leaves_at = kSmallPageHeaderBytes + 1;  // one shape nibble, padded
  const size_t records_at = leaves_at + leaf_section_bytes(t);
  auto expect_corrupt = [&](std::vector<uint8_t> bad, const std::string& what) {
    seal_page(bad);  // compact headers do not store the page's size
    try {
      decode(bad, kPageFormatCurrent);
      FAIL() << what << ": accepted";
    } catch (const CorruptionError& e) {
      EXPECT_TRUE(contains(e.what(), "/x/pages.pbgp: page 0")) << e.what();
    }
  };
  // A record that says it emits without an entry, and one that lost its
  // flag (the surfel section re-encoded with the flipped bit).
  const size_t section = surfel_section_bytes(t);
  for (const size_t surfel : {size_t(1), size_t(0)}) {
    std::vector<uint8_t> records = t.surfel_records;
    records[surfel * kCompactSurfelRecordBytes + 9] ^= 0x80;
    std::vector<uint8_t> other;
    encode_surfel_section(records, leaf_records(t), kPageFormatCurrent, other);
    auto bad = good;
    bad.erase(bad.begin() + long(records_at), bad.begin() + long(records_at + section));
    bad.insert(bad.begin() + long(records_at), other.begin(), other.end());
    expect_corrupt(bad, "flipped emission flag of surfel " + std::to_string(surfel));
  }
  // The surfel section: a column wider than its field (the first column,
  // x, is 10 bits: its width nibble follows them), or cut short.
  {
    auto bad = good;
    bad[records_at + 1] |= 0x3c;  // x's width: bits 10-13 of the section
    bad[records_at + 2] |= 0x03;
    expect_corrupt(bad, "surfel column width 15");
  }
  // V8 shapes are nibbles: the one node's byte has a zero high nibble.
  {
    auto bad = good;
    bad[kSmallPageHeaderBytes] |= 0x10;
    expect_corrupt(bad, "shape padding nibble");
  }
  // The leaf section's widths out of range; its leaf's count one more or
  // one less than the records (which then do not add up to the page).
  for (const uint8_t widths2 : {uint8_t(0xd0) /*count bits 13*/, uint8_t(0x0d) /*radius bits 13*/}) {
    auto bad = good;
    bad[leaves_at + 2] = widths2;
    expect_corrupt(bad, "leaf section widths");
  }
  for (const int delta : {1, -1}) {
    std::vector<LeafRecord> leaves;
    const size_t section = decode_leaf_section(std::span(good).subspan(leaves_at), 1, leaves, "test");
    leaves[0].surfel_count = uint32_t(int(leaves[0].surfel_count) + delta);
    std::vector<uint8_t> other;
    encode_leaf_section(leaves, other);
    auto bad = good;
    bad.erase(bad.begin() + long(leaves_at), bad.begin() + long(leaves_at + section));
    bad.insert(bad.begin() + long(leaves_at), other.begin(), other.end());
    expect_corrupt(bad, "leaf count " + std::to_string(delta));
  }
  // An entry missing, or one too many.
  auto shorter = good;
  shorter.erase(shorter.end() - kSmallPageTrailerBytes - kEmissionEntryBytes, shorter.end() - kSmallPageTrailerBytes);
  expect_corrupt(shorter, "entry missing");
  auto longer = good;
  longer.insert(longer.end() - kSmallPageTrailerBytes, kEmissionEntryBytes, 0);
  expect_corrupt(longer, "entry too many");
  // Truncated, not re-sealed: the checksum (or the size) refuses it.
  for (const size_t cut : {size_t(1), kSmallPageTrailerBytes + 2, good.size() - 10}) {
    const std::vector<uint8_t> cut_page(good.begin(), good.end() - cut);
    EXPECT_THROW(decode(cut_page, kPageFormatCurrent), CorruptionError) << cut;
  }
}

// V8 links (as V6's) store the linked child's rounded payload in 76 bytes:
// exactly what the child's page derives for its root. An exponent byte no
// writer produces, or a payload array of the wrong size, is corruption.
TEST(PageEncoding, LinkPayloadsAreTheChildRootsExactly) {
  struct Keep final : tree::TreeletSink {
    uint32_t write(const tree::Treelet& t) override {
      treelets.push_back(t);
      return uint32_t(treelets.size() - 1);
    }
    std::vector<tree::Treelet> treelets;
  };
  const std::vector<Surfel> surfels = test::random_surfels(2000, 5);
  Keep sink;
  tree::StreamingTreeBuilder b({}, 65536, tree::kRoundedPayloadBytes, sink);
  std::vector<std::pair<uint64_t, size_t>> order;
  const tree::MortonFrame frame(tree::surfel_bounds(surfels));
  for (size_t i = 0; i < surfels.size(); ++i) order.push_back({frame.code(surfels[i].position), i});
  std::sort(order.begin(), order.end());
  for (const auto& [code, i] : order) b.add(surfels[i], code);
  const tree::StreamingTreeStats stats = b.finish();
  const auto codec = make_payload_codec(0);
  std::vector<std::vector<uint8_t>> pages(sink.treelets.size());
  std::vector<std::shared_ptr<tree::Page>> decoded;
  size_t links = 0;
  for (uint32_t id = 0; id < pages.size(); ++id) {
    encode_page(sink.treelets[id], id, *codec, pages[id]);
    decoded.push_back(decode_page(pages[id], {"/x/pages.pbgp", id, 0}, kPageFormatCurrent, *codec, stats.page_count));
    for (const tree::PageLink& l : decoded.back()->links) {
      const tree::Node& root = decoded[l.summary.children[0].page]->nodes[0];
      EXPECT_EQ(l.summary.radiance_sh.r, root.radiance_sh.r);
      EXPECT_EQ(l.summary.radiance_sh.g, root.radiance_sh.g);
      EXPECT_EQ(l.summary.radiance_sh.b, root.radiance_sh.b);
      EXPECT_EQ(l.summary.coverage_sh, root.coverage_sh);
      EXPECT_EQ(l.summary.area, root.area);
      EXPECT_EQ(l.summary.center, root.center);
      EXPECT_EQ(l.summary.radius, root.radius);
      EXPECT_EQ(l.summary.cone_axis, root.cone_axis);
      EXPECT_EQ(l.summary.cone_cos, root.cone_cos);
      ++links;
    }
  }
  EXPECT_GT(links, 50u);
  const uint32_t root = stats.root.page;
  ASSERT_FALSE(sink.treelets[root].links.empty());
  // The root page has no leaves (its treelet is the upper levels).
  ASSERT_TRUE(sink.treelets[root].leaf_records.empty());
  const size_t payload_at = kSmallPageHeaderBytes + (sink.treelets[root].shapes.size() + 1) / 2 +
                            sink.treelets[root].links.size() * kCompactLinkRecordBytes;
  const size_t links_at = kSmallPageHeaderBytes + (sink.treelets[root].shapes.size() + 1) / 2;
  auto expect_corrupt = [&](std::vector<uint8_t> bad, const std::string& what) {
    seal_page(bad, root);
    try {
      decode_page(bad, {"/x/pages.pbgp", root, 0}, kPageFormatCurrent, *codec, stats.page_count);
      FAIL() << what << ": accepted";
    } catch (const CorruptionError& e) {
      EXPECT_TRUE(contains(e.what(), "/x/pages.pbgp: page " + std::to_string(root))) << e.what();
    }
  };
  auto bad = pages[root];
  bad[payload_at] = 255;
  expect_corrupt(bad, "exponent out of range");
  bad = pages[root];
  bad.erase(bad.begin() + long(payload_at));
  expect_corrupt(bad, "payload array a byte short");
  // A link record's fields out of range: the sphere's exponent, its radius
  // past 12 bits, 1 - cos not a half float in [0, 2] (NaN, 3.0), a negative area.
  const auto damage = [&](size_t at, std::vector<uint8_t> value, const std::string& what) {
    auto b = pages[root];
    std::copy(value.begin(), value.end(), b.begin() + long(links_at + at));
    expect_corrupt(b, what);
  };
  damage(4, {255}, "sphere exponent");
  damage(14, {0x00, 0x10}, "radius past 12 bits");
  damage(20, {0x00, 0x7e}, "1 - cos NaN");
  damage(20, {0x00, 0x42}, "1 - cos 3");
  damage(22, {0x00, 0x00, 0x80, 0xbf}, "area -1");
}

// The manifest pairs page formats with payload storage: V4/V6/V8 derived,
// V5/V7/V9 stored; V4-V7 page sets (built before compact records or the
// compact page frame) read.
TEST(PageEncoding, ManifestPairsPageFormatsWithPayloadStorage) {
  Manifest m;
  m.build_key = "k";
  m.stats.page_count = 1;
  m.stats.file_bytes = 100;
  m.pages = {{0, 100}};
  for (const uint32_t format : {kPageFormatV4, kPageFormatV6, kPageFormatV8}) {
    m.page_format = format;
    m.node_payloads = false;
    EXPECT_EQ(decode_manifest(encode_manifest(m), "m").page_format, format);
    m.node_payloads = true;
    EXPECT_THROW(decode_manifest(encode_manifest(m), "m"), CorruptionError) << format;
  }
  for (const uint32_t format : {kPageFormatV5, kPageFormatV7, kPageFormatV9}) {
    m.page_format = format;
    m.node_payloads = true;
    EXPECT_EQ(decode_manifest(encode_manifest(m), "m").page_format, format);
    m.node_payloads = false;
    EXPECT_THROW(decode_manifest(encode_manifest(m), "m"), CorruptionError) << format;
  }
}

// Manifest V5 (with V8/V9 pages): the page table is the pages' sizes,
// LEB128, the offsets their prefix sums.
TEST(PageEncoding, ManifestV5StoresPageSizesOnly) {
  Manifest m;
  m.build_key = "k";
  m.page_format = kPageFormatV8;
  const std::vector<uint32_t> sizes = {40, 127, 128, 16383, 16384, 1u << 30};
  uint64_t at = 0;
  for (const uint32_t b : sizes) {
    m.pages.push_back({at, b});
    at += b;
  }
  m.stats.page_count = uint32_t(sizes.size());
  m.stats.file_bytes = at;
  const auto file = encode_manifest(m);
  EXPECT_EQ(unframe_manifest(file, "m").version, kManifestFormatV5);
  const Manifest back = decode_manifest(file, "m");
  ASSERT_EQ(back.pages.size(), sizes.size());
  for (size_t i = 0; i < sizes.size(); ++i) {
    EXPECT_EQ(back.pages[i].offset, m.pages[i].offset) << i;
    EXPECT_EQ(back.pages[i].bytes, m.pages[i].bytes) << i;
  }
  // 1 + 1 + 2 + 2 + 3 + 5 bytes of sizes, against 12 a page before.
  Manifest v2 = m;
  v2.page_format = kPageFormatV6;
  EXPECT_EQ(encode_manifest(v2).size() - file.size(), 12 * sizes.size() - 14 - 12 /*V5's glossy and leaf fields*/);

  auto expect_corrupt = [&](const Manifest& bad, const std::string& what) {
    try {
      decode_manifest(encode_manifest(bad), "/x/manifest.pbgm");
      FAIL() << what << ": accepted";
    } catch (const CorruptionError& e) {
      EXPECT_TRUE(contains(e.what(), "/x/manifest.pbgm")) << e.what();
    }
  };
  Manifest longer = m;
  longer.stats.file_bytes += 1;  // the sizes do not add up to the file
  expect_corrupt(longer, "sizes short of the file");
  // A V5 table cannot say a page does not follow the previous one.
  Manifest gap = m;
  gap.pages = {};
  for (uint32_t i = 0; i < m.pages.size(); ++i)
    gap.pages.push_back({m.pages[i].offset + (i >= 2 ? 1 : 0), m.pages[i].bytes});
  EXPECT_THROW(encode_manifest(gap), Error);
  // A redundant varint byte (128 as 0x80 0x81 0x00 ...): written by hand.
  auto body = unframe_manifest(file, "m").body;
  std::vector<uint8_t> raw(body.begin(), body.end());
  const size_t table = raw.size() - 12 - (1 + 1 + 2 + 2 + 3 + 5);
  EXPECT_EQ(raw[table], 40u);
  raw.insert(raw.begin() + long(table) + 1, 0x00);
  raw[table] = 40 | 0x80;
  try {
    decode_manifest(frame_manifest(raw, kManifestFormatV5), "/x/manifest.pbgm");
    FAIL() << "redundant varint byte accepted";
  } catch (const CorruptionError& e) {
    EXPECT_TRUE(contains(e.what(), "redundant")) << e.what();
  }
  // V5 manifests go with V8/V9 pages only, and V8/V9 pages with them.
  raw.assign(body.begin(), body.end());
  store_le<uint32_t>(raw.data(), kPageFormatV6);
  EXPECT_THROW(decode_manifest(frame_manifest(raw, kManifestFormatV5), "m"), CorruptionError);
}

}  // namespace
}  // namespace pbgi::storage
