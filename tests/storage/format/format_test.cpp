// Byte order, frames and records of the on-disk format.
#include "common/errors.h"
#include "storage/format/byte_order.h"
#include "storage/format/byte_stream.h"
#include "storage/format/checksum.h"
#include "storage/format/format_version.h"
#include "storage/format/manifest_frame.h"
#include "storage/format/packed_values.h"
#include "storage/format/page_frame.h"
#include "storage/tree/page_records.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <random>

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
  store_le<uint32_t>(b, kSceneEntryMagic);
  EXPECT_EQ(std::string(reinterpret_cast<char*>(b), 4), "PBGS");
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

TEST(Checksum, StreamedInPiecesEqualsOneShot) {
  std::vector<uint8_t> bytes(5000);
  std::iota(bytes.begin(), bytes.end(), uint8_t(3));
  Checksum64Stream empty;
  EXPECT_EQ(empty.digest(), checksum64("", 0));
  Checksum64Stream pieces;
  for (size_t off = 0; off < bytes.size(); off += 777)
    pieces.update(bytes.data() + off, std::min<size_t>(777, bytes.size() - off));
  pieces.update(nullptr, 0);
  EXPECT_EQ(pieces.digest(), checksum64(bytes.data(), bytes.size()));
}

std::vector<uint8_t> sample_page(uint32_t id, uint16_t version = kPageFormatCurrent) {
  const size_t header = is_known_page_format(version) ? page_header_bytes(version) : kPageHeaderBytes;
  const size_t trailer = is_known_page_format(version) ? page_trailer_bytes(version) : kPageTrailerBytes;
  std::vector<uint8_t> page(header + 100 + trailer);
  std::iota(page.begin() + long(header), page.end() - long(trailer), uint8_t(1));
  PageHeader h;
  h.format_version = version;
  h.page_id = id;
  h.node_count = 1;
  h.payload_bytes = 36;
  h.page_bytes = static_cast<uint32_t>(page.size());
  write_page_header(h, page.data());
  seal_page(page, id);
  return page;
}

TEST(PageFrame, HeaderRoundTrip) {
  for (const uint16_t version : {uint16_t(kPageFormatV6), uint16_t(kPageFormatV8), uint16_t(kPageFormatV9),
                                 uint16_t(kPageFormatV10), uint16_t(kPageFormatV11)}) {
    const auto page = sample_page(7, version);
    const PageHeader h = open_page(page, {"pages.pbgp", 7, 8192}, version);
    EXPECT_EQ(h.magic, kPageMagic);
    EXPECT_EQ(h.format_version, version);
    EXPECT_EQ(h.page_id, 7u);
    EXPECT_EQ(h.node_count, 1u);
    // V8/V10 headers do not store the payload array's size (the links give it).
    EXPECT_EQ(h.payload_bytes, version == kPageFormatV8 || version == kPageFormatV10 ? 0u : 36u) << version;
    // V8/V9 headers do not store the page's size: open_page takes the table's.
    EXPECT_EQ(h.page_bytes, page.size());
    // The bytes after the header are untouched.
    EXPECT_EQ(page[page_header_bytes(version)], 1u) << version;
  }
}

// The compact header (V8: 14 bytes, V9: 18) at its documented offsets; a
// writer cannot put more than it holds.
TEST(PageFrame, CompactHeaderFieldsAtTheirOffsets) {
  EXPECT_EQ(page_header_bytes(kPageFormatV8), 14u);
  EXPECT_EQ(page_header_bytes(kPageFormatV9), 18u);
  EXPECT_EQ(page_header_bytes(kPageFormatV6), 32u);
  uint8_t b[18] = {};
  PageHeader h;
  h.format_version = kPageFormatV9;
  h.codec = 1;
  h.flags = kPageFlagNodePayloads | kPageFlagSharedAlbedo;
  h.page_id = 0x01020304;
  h.node_count = 65535;
  h.payload_bytes = 0x0a0b0c0d;
  write_page_header(h, b);
  EXPECT_EQ(load_le<uint32_t>(b), kPageMagic);
  EXPECT_EQ(load_le<uint16_t>(b + 4), kPageFormatV9);
  EXPECT_EQ(b[6], 1u);
  EXPECT_EQ(b[7], kPageFlagNodePayloads | kPageFlagSharedAlbedo);
  EXPECT_EQ(load_le<uint32_t>(b + 8), 0x01020304u);
  EXPECT_EQ(load_le<uint16_t>(b + 12), 65535u);
  EXPECT_EQ(load_le<uint32_t>(b + 14), 0x0a0b0c0du);
  const PageHeader r = read_page_header(b);
  EXPECT_EQ(r.codec, 1u);
  EXPECT_EQ(r.flags, h.flags);
  EXPECT_EQ(r.node_count, 65535u);
  EXPECT_EQ(r.payload_bytes, h.payload_bytes);
  h.node_count = 65536;
  EXPECT_THROW(write_page_header(h, b), Error);
  h.node_count = 1;
  h.flags = 256;
  EXPECT_THROW(write_page_header(h, b), Error);
}

// The small header (V10: 9 bytes, V11: 13) at its documented offsets: no
// codec, no page id (the checksum is seeded with it), and a 4-byte trailer.
TEST(PageFrame, SmallHeaderFieldsAtTheirOffsets) {
  EXPECT_EQ(page_header_bytes(kPageFormatV10), 9u);
  EXPECT_EQ(page_header_bytes(kPageFormatV11), 13u);
  EXPECT_EQ(page_trailer_bytes(kPageFormatV10), 4u);
  EXPECT_EQ(page_trailer_bytes(kPageFormatV9), 8u);
  uint8_t b[13] = {};
  PageHeader h;
  h.format_version = kPageFormatV11;
  h.flags = kPageFlagNodePayloads | kPageFlagGlossy;
  h.node_count = 65535;
  h.payload_bytes = 0x0a0b0c0d;
  write_page_header(h, b);
  EXPECT_EQ(load_le<uint32_t>(b), kPageMagic);
  EXPECT_EQ(load_le<uint16_t>(b + 4), kPageFormatV11);
  EXPECT_EQ(b[6], kPageFlagNodePayloads | kPageFlagGlossy);
  EXPECT_EQ(load_le<uint16_t>(b + 7), 65535u);
  EXPECT_EQ(load_le<uint32_t>(b + 9), 0x0a0b0c0du);
  const PageHeader r = read_page_header(b);
  EXPECT_EQ(r.flags, h.flags);
  EXPECT_EQ(r.node_count, 65535u);
  EXPECT_EQ(r.payload_bytes, h.payload_bytes);
  h.node_count = 65536;
  EXPECT_THROW(write_page_header(h, b), Error);
  // The trailer: the low half of the XXH3-64 seeded with the page id.
  const auto page = sample_page(7, kPageFormatV10);
  const size_t body = page.size() - 4;
  EXPECT_EQ(load_le<uint32_t>(page.data() + body), uint32_t(checksum64(page.data(), body, 7)));
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

// The versions named in a VersionError's "(reads ...)", e.g. {2, 3}.
std::vector<uint32_t> versions_named(const std::string& message) {
  const size_t at = message.find("(reads ");
  const size_t end = message.find(')', at);
  std::vector<uint32_t> out;
  if (at == std::string::npos || end == std::string::npos) return out;
  std::string list = message.substr(at + 7, end - at - 7);
  for (size_t pos = 0; pos < list.size();) {
    size_t next = list.find(", ", pos);
    if (next == std::string::npos) next = list.size();
    out.push_back(uint32_t(std::stoul(list.substr(pos, next - pos))));
    pos = next + 2;
  }
  return out;
}

std::vector<uint32_t> versions_accepted(bool (*is_known)(uint32_t)) {
  std::vector<uint32_t> out;
  for (uint32_t v = 1; v < 256; ++v) {
    if (is_known(v)) out.push_back(v);
  }
  return out;
}

// The message named only the current version although two page formats
// and V1-V4 manifests are read.
TEST(PageFrame, VersionErrorNamesEveryVersionRead) {
  const auto page = sample_page(3, 99);
  try {
    open_page(page, {"p", 3, 0}, kPageFormatCurrent);
    FAIL() << "version 99 accepted";
  } catch (const VersionError& e) {
    EXPECT_EQ(versions_named(e.what()), versions_accepted(is_known_page_format)) << e.what();
    EXPECT_GE(versions_accepted(is_known_page_format).size(), 2u);
  }
}

TEST(ManifestFrame, VersionErrorNamesEveryVersionRead) {
  const std::vector<uint8_t> body{1, 2, 3};
  try {
    unframe_manifest(frame_manifest(body, kManifestFormatLatest + 1), "m.pbgm");
    FAIL() << "unknown manifest version accepted";
  } catch (const VersionError& e) {
    EXPECT_EQ(versions_named(e.what()), versions_accepted(is_known_manifest_format)) << e.what();
    EXPECT_GE(versions_accepted(is_known_manifest_format).size(), 2u);
  }
}

// Pages of the formats before cut-shaped treelets (V2, V3) are refused as
// a version, not read: the message asks for a rebuild (the daemon's build
// keys changed with kPageSetFormatVersion, so it rebuilds on its own).
TEST(PageFrame, RetiredVersionIsVersionErrorAskingForARebuild) {
  for (const uint16_t v : {uint16_t(kPageFormatV2), uint16_t(kPageFormatV3)}) {
    const auto page = sample_page(3, v);
    try {
      open_page(page, {"/x/pages.pbgp", 3, 0}, kPageFormatCurrent);
      FAIL() << "page format " << v << " accepted";
    } catch (const VersionError& e) {
      const std::string m = e.what();
      EXPECT_TRUE(contains(m, "/x/pages.pbgp")) << m;
      EXPECT_TRUE(contains(m, "page format version " + std::to_string(v))) << m;
      EXPECT_TRUE(contains(m, "rebuild")) << m;
      EXPECT_EQ(versions_named(m), versions_accepted(is_known_page_format)) << m;
    }
  }
}

TEST(PageFrame, WrongPlaceIsCorruption) {
  const auto page = sample_page(3);
  EXPECT_THROW(open_page(page, {"p", 4, 0}, kPageFormatCurrent), CorruptionError);  // page id
  for (const uint16_t version : {uint16_t(kPageFormatV8), uint16_t(kPageFormatV10)}) {
    try {
      open_page(sample_page(3, version), {"/x/pages.pbgp", 4, 0}, version);
      FAIL() << "page 3 of format " << version << " read as page 4";
    } catch (const CorruptionError& e) {
      // V8 names the header's id; V10's checksum, seeded with the id, fails.
      EXPECT_TRUE(contains(e.what(), version == kPageFormatV8 ? "header names page 3" : "checksum mismatch"))
          << e.what();
    }
  }
  auto short_page = std::vector<uint8_t>(page.begin(), page.begin() + 20);
  EXPECT_THROW(open_page(short_page, {"p", 3, 0}, kPageFormatCurrent), CorruptionError);
  // Sealed and long enough for a V8 header, too short for V6's 32 bytes.
  std::vector<uint8_t> v6(kCompactPageHeaderBytes + 4 + kPageTrailerBytes, 0);
  store_le<uint32_t>(v6.data(), kPageMagic);
  store_le<uint16_t>(v6.data() + 4, uint16_t(kPageFormatV6));
  seal_page(v6);
  try {
    open_page(v6, {"/x/pages.pbgp", 3, 0}, kPageFormatV6);
    FAIL() << "a 26-byte V6 page accepted";
  } catch (const CorruptionError& e) {
    EXPECT_TRUE(contains(e.what(), "/x/pages.pbgp: page 3")) << e.what();
  }
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
  EXPECT_THROW(unframe_manifest(frame_manifest(body, kManifestFormatLatest + 1), "m.pbgm"), VersionError);
  // Truncated.
  EXPECT_THROW(unframe_manifest(std::span(file).first(file.size() - 1), "m.pbgm"), CorruptionError);
  EXPECT_THROW(unframe_manifest(std::span(file).first(10), "m.pbgm"), CorruptionError);
}

TEST(PageRecords, ShapeLeafAndLinkRoundTrip) {
  for (uint8_t byte = 0;; ++byte) {
    NodeShape sh;
    const bool ok = decode_shape(byte, sh);
    // Valid: 0 (leaf), 1 child (+ext0), 2 children (+ext0, +ext1).
    const uint8_t count = byte & 3;
    const bool e0 = byte & 4, e1 = byte & 8;
    const bool want = (byte & 0xf0) == 0 && count <= 2 && (!e0 || count >= 1) && (!e1 || count >= 2);
    EXPECT_EQ(ok, want) << int(byte);
    if (ok) {
      EXPECT_EQ(encode_shape(sh), byte);
    }
    if (byte == 255) break;
  }

  uint8_t leaf[kLeafRecordBytes];
  write_leaf_record({{1, -2, 3.5f}, 0.25f}, 4096, leaf);
  LeafFrame f;
  uint32_t count = 0;
  read_leaf_record(leaf, f, count);
  EXPECT_EQ(f.center, Imath::V3f(1, -2, 3.5f));
  EXPECT_EQ(f.radius, 0.25f);
  EXPECT_EQ(count, 4096u);
  EXPECT_EQ(load_le<uint16_t>(leaf + 16), 4096u);  // at the documented offset

  tree::Node n;
  n.center = {1, -2, 3.5f};
  n.radius = 0.25f;
  n.cone_axis = {0, 1, 0};
  n.cone_cos = 0.5f;
  n.area = 9;
  uint8_t link[kLinkRecordBytes];
  write_link_record(77, n, link);
  tree::Node m;
  uint32_t page = 0;
  read_link_record(link, page, m);
  EXPECT_EQ(page, 77u);
  EXPECT_EQ(m.center, n.center);
  EXPECT_EQ(m.radius, n.radius);
  EXPECT_EQ(m.cone_axis, n.cone_axis);
  EXPECT_EQ(m.cone_cos, n.cone_cos);
  EXPECT_EQ(m.area, n.area);
  EXPECT_EQ(load_le<float>(link + 36), 9.f);  // last field at the documented offset
}

TEST(PackedValues, Rgb9e5WithinItsStatedPrecision) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  for (int i = 0; i < 200000; ++i) {
    // Magnitudes from 1e-6 to 6e4, channels from equal to 1000:1 apart.
    const float scale = std::pow(10.f, -6.f + 10.7f * u(rng));
    const Imath::C3f c(scale * u(rng), scale * std::pow(u(rng), 3.f), scale * u(rng));
    const Imath::C3f d = decode_rgb9e5(encode_rgb9e5(c));
    const float maxc = std::max({c.x, c.y, c.z});
    const float tol = std::max(maxc / 512.f, 0x1p-25f) * 1.0001f;
    ASSERT_NEAR(d.x, c.x, tol) << c;
    ASSERT_NEAR(d.y, c.y, tol) << c;
    ASSERT_NEAR(d.z, c.z, tol) << c;
  }
  EXPECT_EQ(decode_rgb9e5(encode_rgb9e5({0, 0, 0})), Imath::C3f(0.f));
  EXPECT_EQ(decode_rgb9e5(encode_rgb9e5({1, 0.5f, 0.25f})), Imath::C3f(1, 0.5f, 0.25f));  // exact
  EXPECT_EQ(decode_rgb9e5(encode_rgb9e5({1e9f, 0, 0})).x, kRgb9e5Max);                    // clamped
  EXPECT_EQ(decode_rgb9e5(encode_rgb9e5({-1, 2, 0})).x, 0.f);
}

// Angle between unit vectors, accurate also for tiny angles (acos of a
// float dot product cannot resolve below ~3e-4 rad).
double angle_between(const Imath::V3f& a, const Imath::V3f& b) {
  const Imath::V3d x(a.x, a.y, a.z), y(b.x, b.y, b.z);
  return std::atan2(x.cross(y).length(), x.dot(y));
}

// Every one of `samples` random unit vectors and of a few axes and edges
// of the octahedron comes back from `code` (vector -> decoded vector) unit
// length and within `bound` radians; prints the worst angle.
template <class Code>
void expect_octahedral_within(uint32_t seed, int samples, double bound, const char* what, Code code) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> g(0.f, 1.f);
  double worst = 0;
  auto check = [&](Imath::V3f n) {
    n.normalize();
    const Imath::V3f d = code(n);
    ASSERT_NEAR(d.length(), 1.f, 1e-6f);
    const double angle = angle_between(d, n);
    worst = std::max(worst, angle);
    ASSERT_LE(angle, bound) << n;
  };
  for (int i = 0; i < samples; ++i) check({g(rng), g(rng), g(rng)});
  for (const Imath::V3f& n : {Imath::V3f(0, 0, 1), Imath::V3f(0, 0, -1), Imath::V3f(1, 0, 0), Imath::V3f(0, -1, 0),
                              Imath::V3f(1, 1, 0), Imath::V3f(-1, 1, -1e-8f)})
    check(n);
  std::printf("octahedral %s: worst angle %.3g rad\n", what, worst);
}

TEST(PackedValues, OctahedralWithinItsStatedAngle) {
  expect_octahedral_within(6, 200000, kOctahedralMaxAngle, "2x16 bits",
                           [](const Imath::V3f& n) { return decode_octahedral(encode_octahedral(n)); });
}

TEST(PackedValues, Octahedral12WithinItsStatedAngle) {
  expect_octahedral_within(16, 2000000, kOctahedral12MaxAngle, "2x12 bits", [](const Imath::V3f& n) {
    const uint32_t code = encode_octahedral_bits(n, 12);
    EXPECT_LT(code, 1u << 24);
    return decode_octahedral_bits(code, 12);
  });
}

TEST(PackedValues, NarrowFixedPointWithinHalfAStep) {
  for (const int bits : {13, 14}) {
    const float top_s = float((1 << (bits - 1)) - 1), top_u = float((1 << bits) - 1);
    for (int i = -10000; i <= 10000; ++i) {
      const float x = float(i) / 10000.f;
      const uint32_t q = encode_snorm_bits(x, bits);
      ASSERT_LT(q, 1u << bits);
      ASSERT_NEAR(decode_snorm_bits(q, bits), x, 0.5f / top_s + 1e-7f);
      if (x >= 0.f) {
        ASSERT_NEAR(decode_unorm_bits(encode_unorm_bits(x, bits), bits), x, 0.5f / top_u + 1e-7f);
      }
    }
    EXPECT_EQ(decode_snorm_bits(encode_snorm_bits(-1.f, bits), bits), -1.f);
    EXPECT_EQ(decode_snorm_bits(encode_snorm_bits(1.f, bits), bits), 1.f);
    EXPECT_EQ(decode_snorm_bits(encode_snorm_bits(0.f, bits), bits), 0.f);
    EXPECT_EQ(decode_unorm_bits(encode_unorm_bits(1.f, bits), bits), 1.f);
  }
}

// A surfel inside `frame` (its disk within the sphere), random but for
// the colours, which the tests set.
Surfel random_surfel_in(const LeafFrame& frame, std::mt19937& rng) {
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  Surfel s;
  s.position = frame.center + 0.55f * frame.radius * Imath::V3f(u(rng), u(rng), u(rng));
  s.normal = Imath::V3f(u(rng), u(rng), u(rng) + 0.01f).normalized();
  s.radius = 0.4f * frame.radius * (u(rng) + 1.f) / 2.f;
  s.albedo = {0.5f + 0.5f * u(rng), 0.25f, 0.f};
  return s;
}

TEST(PageRecords, SurfelRecordWithinItsStatedPrecision) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  const LeafFrame frame{{10.f, -3.f, 250.f}, 0.37f};
  for (int i = 0; i < 100000; ++i) {
    Surfel s = random_surfel_in(frame, rng);
    s.emission = {0, 0, 0};
    s.radiance = {100.f * (u(rng) + 1.f), 3.f, 0.125f};
    uint8_t rec[kRelativeSurfelRecordBytes];
    encode_surfel_record(SurfelRecords::kRelative, s, frame, rec);
    Surfel d;
    decode_surfel_record(SurfelRecords::kRelative, rec, frame, d);
    // Documented: R/65534 per coordinate, R/131070 for the radius (plus
    // float rounding of center + offset).
    const float ulp = 250.f * 0x1p-23f;
    for (int k = 0; k < 3; ++k) ASSERT_NEAR(d.position[k], s.position[k], frame.radius / 65534.f + ulp);
    ASSERT_NEAR(d.radius, s.radius, frame.radius / 131070.f + 1e-7f);
    ASSERT_LE(angle_between(d.normal, s.normal), kOctahedralMaxAngle);
    ASSERT_NEAR(d.albedo.x, s.albedo.x, std::max(s.albedo.x, 0.25f) / 512.f);
    ASSERT_EQ(d.emission, Imath::C3f(0.f));
    ASSERT_NEAR(d.radiance.x, s.radiance.x, std::max(s.radiance.x, 3.f) / 512.f);
  }
}

// `s` through a record of `format` in the unit frame at the origin.
Surfel round_trip(SurfelRecords format, const Surfel& s) {
  const LeafFrame frame{{0, 0, 0}, 1.f};
  uint8_t rec[kHalfSurfelRecordBytes];
  encode_surfel_record(format, s, frame, rec);
  Surfel d;
  decode_surfel_record(format, rec, frame, d);
  return d;
}

Surfel unit_disk_surfel() {
  Surfel s;
  s.normal = {0, 0, 1};
  s.radius = 0.5f;
  return s;
}

// Compact records (V6/V7 pages): the precision page_records.h states, and
// the emission out of line: a flag in the record, the value an entry.
TEST(PageRecords, CompactSurfelRecordWithinItsStatedPrecision) {
  std::mt19937 rng(17);
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  const LeafFrame frame{{10.f, -3.f, 250.f}, 0.37f};
  double worst_normal = 0;
  for (int i = 0; i < 100000; ++i) {
    Surfel s = random_surfel_in(frame, rng);
    const bool emits = i % 3 == 0;
    s.emission = emits ? Imath::C3f(5.f * (u(rng) + 1.f) + 1e-3f, 0.5f, 0.f) : Imath::C3f(0.f);
    s.radiance = {100.f * (u(rng) + 1.f), 3.f, 0.125f};
    uint8_t rec[kCompactSurfelRecordBytes];
    encode_surfel_record(SurfelRecords::kCompact, s, frame, rec);
    Surfel d;
    d.emission = {7, 7, 7};
    decode_surfel_record(SurfelRecords::kCompact, rec, frame, d);
    // Documented: R/16382 per coordinate and for the radius (plus float
    // rounding of center + offset), kOctahedral12MaxAngle for the normal.
    const float ulp = 250.f * 0x1p-23f;
    for (int k = 0; k < 3; ++k) ASSERT_NEAR(d.position[k], s.position[k], frame.radius / 16382.f + ulp);
    ASSERT_NEAR(d.radius, s.radius, frame.radius / 16382.f + 1e-7f);
    const double angle = angle_between(d.normal, s.normal);
    worst_normal = std::max(worst_normal, angle);
    ASSERT_LE(angle, kOctahedral12MaxAngle);
    ASSERT_EQ(d.albedo, decode_rgb9e5(encode_rgb9e5(s.albedo)));
    ASSERT_EQ(d.radiance, decode_rgb9e5(encode_rgb9e5(s.radiance)));
    // Emission: not in the record; the record says whether it emits.
    ASSERT_EQ(d.emission, Imath::C3f(0.f));
    ASSERT_EQ(surfel_record_emits(SurfelRecords::kCompact, rec), emits);
    ASSERT_FALSE(surfel_record_emits(SurfelRecords::kRelative, rec));
    uint8_t entry[kEmissionEntryBytes];
    write_emission_entry(s, entry);
    ASSERT_EQ(read_emission_entry(entry), decode_rgb9e5(encode_rgb9e5(s.emission)));
  }
  std::printf("compact leaf records: worst normal angle %.3g rad\n", worst_normal);
}

// A leaf's positions on the grid of position_grid_shift: shift 4 (10 bits)
// where the frame is a few surfel radii, 0 (14 bits) where it is hundreds;
// every coordinate within half a step, a whole one near the frame's edge,
// and the codes end in `shift` one bits (what V10 surfel sections store
// in fewer bits).
TEST(PageRecords, CompactPositionsOnTheirLeafsGrid) {
  EXPECT_EQ(position_grid_shift(1.f, 0.5f), 4);
  EXPECT_EQ(position_grid_shift(1.f, 0.f), 0);
  EXPECT_EQ(position_grid_shift(300.f, 1.f), 0);
  EXPECT_EQ(position_grid_shift(32.f, 1.f), 2);  // 2^s 32 R <= 8191 r: s = 2
  std::mt19937 rng(23);
  const LeafFrame frame{{1.f, 2.f, -3.f}, 0.25f};
  for (const int shift : {1, 3, 4}) {
    const float step = float(1 << shift) * frame.radius / 8191.f;
    for (int i = 0; i < 20000; ++i) {
      Surfel s = random_surfel_in(frame, rng);
      uint8_t rec[kCompactSurfelRecordBytes];
      encode_surfel_record(SurfelRecords::kCompact, s, frame, rec, shift);
      Surfel d;
      decode_surfel_record(SurfelRecords::kCompact, rec, frame, d);
      const auto g = load_le<uint64_t>(rec);
      for (int k = 0; k < 3; ++k) {
        const auto code = uint32_t((g >> (14 * k)) & 0x3fffu);
        ASSERT_GE(std::countr_one(code), shift) << code;
        const float offset = std::abs(s.position[k] - frame.center[k]);
        const float bound = offset > frame.radius - step ? step : step / 2;
        ASSERT_NEAR(d.position[k], s.position[k], bound * 1.001f + 1e-6f) << shift << " " << offset;
      }
    }
  }
}

// Emission below RGB9E5's smallest step is zero in every layout: such a
// surfel has no entry (the 24-byte record decodes it as zero too).
TEST(PageRecords, CompactRecordOfATinyEmissionHasNoEntry) {
  Surfel s = unit_disk_surfel();
  s.emission = {1e-12f, 0.f, 0.f};
  uint8_t rec[kCompactSurfelRecordBytes];
  encode_surfel_record(SurfelRecords::kCompact, s, {{0, 0, 0}, 1.f}, rec);
  EXPECT_FALSE(surfel_record_emits(SurfelRecords::kCompact, rec));
  EXPECT_EQ(round_trip(SurfelRecords::kRelative, s).emission, Imath::C3f(0.f));
}

// Format A (half): positions exact, the rest within the precision
// page_records.h states, for bright and dim colours alike.
TEST(PageRecords, HalfSurfelRecordWithinItsStatedPrecision) {
  std::mt19937 rng(8);
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  const LeafFrame frame{{1e5f, -3.f, 250.f}, 0.37f};
  double worst_normal = 0;
  for (int i = 0; i < 100000; ++i) {
    Surfel s = random_surfel_in(frame, rng);
    s.emission = {1e-6f, 0, 40000.f};
    s.radiance = {100.f * (u(rng) + 1.f), 3.f, 1e-3f * (u(rng) + 1.f)};
    uint8_t rec[kHalfSurfelRecordBytes];
    encode_surfel_record(SurfelRecords::kHalf, s, frame, rec);
    Surfel d;
    decode_surfel_record(SurfelRecords::kHalf, rec, frame, d);
    ASSERT_EQ(d.position, s.position);  // float32, stored as is
    ASSERT_NEAR(d.radius, s.radius, frame.radius / 4096.f);
    ASSERT_NEAR(d.normal.length(), 1.f, 1e-6f);
    const double angle = angle_between(d.normal, s.normal);
    worst_normal = std::max(worst_normal, angle);
    ASSERT_LE(angle, 1e-3);
    auto near_rel = [](float got, float want) {
      // 2^-11 of itself above half's smallest normal, 6e-8 below.
      return std::abs(got - want) <= std::max(want * 0x1p-11f, 6e-8f);
    };
    for (int c = 0; c < 3; ++c) {
      ASSERT_TRUE(near_rel(d.albedo[c], s.albedo[c])) << c << " " << d.albedo[c] << " " << s.albedo[c];
      ASSERT_TRUE(near_rel(d.emission[c], s.emission[c])) << c << " " << d.emission[c] << " " << s.emission[c];
      ASSERT_TRUE(near_rel(d.radiance[c], s.radiance[c])) << c << " " << d.radiance[c] << " " << s.radiance[c];
    }
  }
  std::printf("half leaf records: worst normal angle %.3g rad\n", worst_normal);
}

// Half colours keep what RGB9E5's shared exponent loses: a dim channel
// next to a bright one.
TEST(PageRecords, HalfKeepsDimChannelsNextToBrightOnes) {
  Surfel s = unit_disk_surfel();
  s.radiance = {1000.f, 0.01f, 0.f};
  const Surfel relative = round_trip(SurfelRecords::kRelative, s), half = round_trip(SurfelRecords::kHalf, s);
  EXPECT_EQ(round_trip(SurfelRecords::kCompact, s).radiance.y, 0.f);  // the same RGB9E5
  EXPECT_EQ(relative.radiance.y, 0.f);                                // below max/512: flushed by the shared exponent
  EXPECT_NEAR(half.radiance.y, 0.01f, 0.01f * 0x1p-11f);
}

// Out-of-range values clamp to half's largest finite value: never inf.
TEST(PageRecords, HalfClampsInsteadOfOverflowing) {
  Surfel s = unit_disk_surfel();
  s.emission = {1e9f, 0.f, 0.f};
  s.radiance = {1e9f, 0.f, 0.f};
  const Surfel d = round_trip(SurfelRecords::kHalf, s);
  EXPECT_EQ(d.emission.x, 65504.f);
  EXPECT_EQ(d.radiance.x, 65504.f);
}

TEST(PageRecords, LeafFormatNames) {
  EXPECT_EQ(parse_leaf_format("relative"), LeafFormat::kRelative);
  EXPECT_EQ(parse_leaf_format("half"), LeafFormat::kHalf);
  EXPECT_EQ(to_string(LeafFormat::kHalf), "half");
  try {
    parse_leaf_format("A");
    FAIL() << "accepted an unknown leaf format";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("relative, half"), std::string::npos) << e.what();
  }
  // Large leaves (not the internal node) set the minimum: the half record
  // is 20 bytes longer than the compact one, which counts an emission entry
  // (4 bytes) for every surfel.
  EXPECT_EQ(min_page_bytes(64, LeafFormat::kHalf), min_page_bytes(64, LeafFormat::kRelative) + 64 * 16);
  EXPECT_EQ(written_surfel_records(LeafFormat::kRelative), SurfelRecords::kCompact);
  EXPECT_EQ(surfel_records_of(LeafFormat::kRelative, false), SurfelRecords::kRelative);
  EXPECT_EQ(surfel_records_of(LeafFormat::kHalf, false), SurfelRecords::kHalf);
  EXPECT_EQ(surfel_record_bytes(SurfelRecords::kCompact), 18u);
}

// Rounded leaf frames (V8/V9 leaf records): the rounded sphere contains the
// given one and is at most (1 + sqrt(3)/2 + 1) grid steps larger, the step
// being at most radius / 1024 or, for frames far from the origin, at most
// 2^-21 of the largest centre coordinate (FORMAT.md); rounding is exact
// for a compact record.
TEST(PageRecords, RoundedFrameContainsTheSphereWithinItsBound) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  double worst_growth = 0;
  for (int i = 0; i < 200000; ++i) {
    const float scale = std::pow(10.f, 5.f * u(rng));                   // centres 1e-5 .. 1e5
    const float radius = std::pow(10.f, -4.f + 3.5f * (u(rng) + 1.f));  // 1e-4 .. 1e3
    const LeafFrame f{{scale * u(rng), scale * u(rng), scale * u(rng)}, i % 1000 == 0 ? 0.f : radius};
    const RoundedFrame r = round_frame_outward(f);
    const LeafFrame g = r.frame();
    const double moved =
        std::sqrt(std::pow(double(g.center.x) - f.center.x, 2) + std::pow(double(g.center.y) - f.center.y, 2) +
                  std::pow(double(g.center.z) - f.center.z, 2));
    ASSERT_LE(moved + f.radius, double(g.radius)) << i;  // contains
    const double largest = std::max({std::abs(f.center.x), std::abs(f.center.y), std::abs(f.center.z)});
    const double step = std::ldexp(1.0, r.exponent);
    ASSERT_TRUE(step <= f.radius / 1024.0 || step <= largest * 0x1p-21 || r.exponent == kMinFrameExponent) << i;
    ASSERT_LE(double(g.radius), f.radius + (std::sqrt(3.0) / 2 + 1) * step) << i;
    if (step <= f.radius / 1024.0) worst_growth = std::max(worst_growth, (double(g.radius) - f.radius) / f.radius);
    // A compact record holds it exactly.
    RoundedFrame back;
    ASSERT_TRUE(to_rounded_frame(g, back)) << i;
    ASSERT_EQ(back.frame().center, g.center);
    ASSERT_EQ(back.frame().radius, g.radius);
  }
  std::printf("rounded frames: radius grows by at most %.3g of itself (grid from the radius)\n", worst_growth);
  EXPECT_LE(worst_growth, (std::sqrt(3.0) / 2 + 1) / 1024);
  // Not every frame is rounded: 0.1 and radius 1 need a grid of 2^-27,
  // on which the radius is 2^27 steps.
  RoundedFrame r;
  EXPECT_FALSE(to_rounded_frame({{0.1f, 0.f, 0.f}, 1.f}, r));
  EXPECT_FALSE(to_rounded_frame({{std::nanf(""), 0.f, 0.f}, 1.f}, r));
  EXPECT_THROW(round_frame_outward({{0.f, 0.f, 0.f}, 3e38f}), InvalidArgument);
}

}  // namespace
}  // namespace pbgi::storage
