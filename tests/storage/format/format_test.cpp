// Byte order, frames and records of the on-disk format.
#include "storage/format/byte_order.h"
#include "storage/format/byte_stream.h"
#include "storage/format/checksum.h"
#include "storage/format/errors.h"
#include "storage/format/format_version.h"
#include "storage/format/manifest_frame.h"
#include "storage/format/page_frame.h"
#include "storage/format/page_records.h"

#include <gtest/gtest.h>

#include <numeric>

namespace pbgi::storage {
namespace {

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

TEST(ByteOrder, LittleEndianOnDisk) {
  uint8_t b[8];
  store_le<uint32_t>(b, 0x01020304u);
  EXPECT_EQ(b[0], 0x04);
  EXPECT_EQ(b[3], 0x01);
  EXPECT_EQ(load_le<uint32_t>(b), 0x01020304u);
  store_le<uint64_t>(b, 0x0102030405060708ull);
  EXPECT_EQ(b[0], 0x08);
  EXPECT_EQ(b[7], 0x01);
  store_le<float>(b, 1.0f);  // 0x3f800000
  EXPECT_EQ(b[3], 0x3f);
  EXPECT_EQ(b[2], 0x80);
  EXPECT_EQ(load_le<float>(b), 1.0f);
  store_le<uint16_t>(b, 0xabcd);
  EXPECT_EQ(b[0], 0xcd);
}

TEST(ByteOrder, MagicsReadAsLetters) {
  uint8_t b[4];
  store_le<uint32_t>(b, kPageMagic);
  EXPECT_EQ(std::string(reinterpret_cast<char*>(b), 4), "PBGP");
  store_le<uint32_t>(b, kManifestMagic);
  EXPECT_EQ(std::string(reinterpret_cast<char*>(b), 4), "PBGM");
}

TEST(ByteStream, RoundTripAndTruncation) {
  std::vector<uint8_t> buf;
  ByteWriter w(buf);
  w.put<uint32_t>(7);
  w.put<uint64_t>(1ull << 40);
  w.put<float>(-2.5f);
  w.put_string("key");
  ByteReader r(buf, "test.bin", 100);
  EXPECT_EQ(r.get<uint32_t>("a"), 7u);
  EXPECT_EQ(r.get<uint64_t>("b"), 1ull << 40);
  EXPECT_EQ(r.get<float>("c"), -2.5f);
  EXPECT_EQ(r.get_string("d", 16), "key");
  r.expect_end();
  try {
    r.get<uint32_t>("missing");
    FAIL();
  } catch (const CorruptionError& e) {
    EXPECT_TRUE(contains(e.what(), "test.bin")) << e.what();
    EXPECT_TRUE(contains(e.what(), "offset " + std::to_string(100 + buf.size()))) << e.what();
    EXPECT_TRUE(contains(e.what(), "missing")) << e.what();
  }
  ByteReader r2(buf, "test.bin");
  r2.get<uint32_t>("a");
  r2.get<uint64_t>("b");
  r2.get<float>("c");
  EXPECT_THROW(r2.get_string("d", 2), CorruptionError);  // length above the limit
}

TEST(Checksum, IsXxh3Of64Bits) {
  // XXH3_64bits of the empty input (seed 0), from the xxHash test vectors.
  EXPECT_EQ(checksum64("", 0), 0x2D06800538D394C2ull);
  EXPECT_EQ(checksum_hex(0x2D06800538D394C2ull), "0x2d06800538d394c2");
}

std::vector<uint8_t> sample_page(uint32_t id, uint16_t version = kPageFormatCurrent) {
  std::vector<uint8_t> page(kPageHeaderBytes + 100 + kPageTrailerBytes);
  std::iota(page.begin() + kPageHeaderBytes, page.end() - kPageTrailerBytes, uint8_t(1));
  PageHeader h;
  h.format_version = version;
  h.page_id = id;
  h.node_count = 1;
  h.payload_bytes = 36;
  h.page_bytes = static_cast<uint32_t>(page.size());
  write_page_header(h, page.data());
  seal_page(page);
  return page;
}

TEST(PageFrame, HeaderRoundTrip) {
  const auto page = sample_page(7);
  const PageHeader h = open_page(page, {"pages.pbgp", 7, 8192}, kPageFormatCurrent);
  EXPECT_EQ(h.magic, kPageMagic);
  EXPECT_EQ(h.page_id, 7u);
  EXPECT_EQ(h.node_count, 1u);
  EXPECT_EQ(h.payload_bytes, 36u);
  EXPECT_EQ(h.page_bytes, page.size());
}

TEST(PageFrame, EveryFlippedByteIsCorruptionNamingThePage) {
  const auto good = sample_page(7);
  for (size_t i = 0; i < good.size(); ++i) {
    auto bad = good;
    bad[i] ^= 0x10;
    try {
      open_page(bad, {"/x/pages.pbgp", 7, 8192}, kPageFormatCurrent);
      FAIL() << "flip at byte " << i << " not detected";
    } catch (const CorruptionError& e) {
      const std::string m = e.what();
      EXPECT_TRUE(contains(m, "/x/pages.pbgp")) << m;
      EXPECT_TRUE(contains(m, "page 7")) << m;
      EXPECT_TRUE(contains(m, "offset 8192")) << m;
      EXPECT_TRUE(contains(m, "expected 0x")) << m;
      EXPECT_TRUE(contains(m, "found 0x")) << m;
    }
  }
}

TEST(PageFrame, UnknownVersionIsVersionError) {
  const auto page = sample_page(3, 99);  // correctly sealed, from a "newer" writer
  EXPECT_THROW(open_page(page, {"p", 3, 0}, kPageFormatCurrent), VersionError);
}

TEST(PageFrame, WrongPlaceIsCorruption) {
  const auto page = sample_page(3);
  EXPECT_THROW(open_page(page, {"p", 4, 0}, kPageFormatCurrent), CorruptionError);  // page id
  auto short_page = std::vector<uint8_t>(page.begin(), page.begin() + 20);
  EXPECT_THROW(open_page(short_page, {"p", 3, 0}, kPageFormatCurrent), CorruptionError);
}

TEST(ManifestFrame, RoundTripAndDamage) {
  const std::vector<uint8_t> body{1, 2, 3, 4, 5, 6, 7, 8, 9};
  const auto file = frame_manifest(body);
  const ManifestBody mb = unframe_manifest(file, "m.pbgm");
  EXPECT_EQ(mb.version, kManifestFormatCurrent);
  EXPECT_EQ(std::vector<uint8_t>(mb.body.begin(), mb.body.end()), body);

  for (size_t i = 0; i < file.size(); ++i) {
    auto bad = file;
    bad[i] ^= 0x01;
    try {
      unframe_manifest(bad, "m.pbgm");
      FAIL() << "flip at byte " << i << " not detected";
    } catch (const VersionError& e) {
      EXPECT_TRUE(i >= 4 && i < 8) << "version error from byte " << i;
    } catch (const CorruptionError& e) {
      EXPECT_TRUE(contains(e.what(), "m.pbgm")) << e.what();
    }
  }
  // A correctly checksummed manifest of an unknown version.
  EXPECT_THROW(unframe_manifest(frame_manifest(body, 2), "m.pbgm"), VersionError);
  // Truncated.
  EXPECT_THROW(unframe_manifest(std::span(file).first(file.size() - 1), "m.pbgm"), CorruptionError);
  EXPECT_THROW(unframe_manifest(std::span(file).first(10), "m.pbgm"), CorruptionError);
}

TEST(PageRecords, RoundTrip) {
  tree::Node n;
  n.center = {1, -2, 3.5f};
  n.radius = 0.25f;
  n.cone_axis = {0, 1, 0};
  n.cone_cos = 0.5f;
  n.area = 9;
  n.child_count = 2;
  n.children[0] = {3, 4};
  n.children[1] = {5, 6};
  uint8_t buf[kTopologyRecordBytes];
  write_topology_record(n, buf);
  tree::Node m;
  read_topology_record(buf, m);
  EXPECT_EQ(m.center, n.center);
  EXPECT_EQ(m.radius, n.radius);
  EXPECT_EQ(m.cone_axis, n.cone_axis);
  EXPECT_EQ(m.cone_cos, n.cone_cos);
  EXPECT_EQ(m.area, n.area);
  EXPECT_EQ(m.child_count, 2u);
  EXPECT_EQ(m.children[0], n.children[0]);
  EXPECT_EQ(m.children[1], n.children[1]);

  Surfel s;
  s.position = {1, 2, 3};
  s.normal = {0, 0, 1};
  s.radius = 0.1f;
  s.albedo = {0.1f, 0.2f, 0.3f};
  s.emission = {4, 5, 6};
  s.radiance = {7, 8, 9};
  uint8_t sb[kSurfelRecordBytes];
  write_surfel_record(s, sb);
  Surfel t;
  read_surfel_record(sb, t);
  EXPECT_EQ(t.position, s.position);
  EXPECT_EQ(t.normal, s.normal);
  EXPECT_EQ(t.radius, s.radius);
  EXPECT_EQ(t.albedo, s.albedo);
  EXPECT_EQ(t.emission, s.emission);
  EXPECT_EQ(t.radiance, s.radiance);
  EXPECT_EQ(load_le<float>(sb + 60), 9.f);  // last field at the documented offset
}

}  // namespace
}  // namespace pbgi::storage
