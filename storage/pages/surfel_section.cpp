#include "storage/pages/surfel_section.h"

#include "common/errors.h"
#include "storage/codecs/bit_packing.h"
#include "storage/format/byte_order.h"
#include "storage/tree/leaf_format.h"

#include <algorithm>
#include <bit>
#include <cstring>

namespace pbgi::storage {

namespace {

// A field of the compact record: `word` 0 is the 80-bit G (bytes 0-9), 1
// the albedo (u32 at 10), 2 the radiance (u32 at 14).
struct Column {
  int word;
  uint32_t shift, bits;
};
constexpr Column kColumns[] = {{0, 0, 14},  {0, 14, 14}, {0, 28, 14}, {0, 42, 12},
                               {0, 54, 12}, {0, 66, 13}, {0, 79, 1},                // G
                               {1, 0, 9},   {1, 9, 9},   {1, 18, 9},  {1, 27, 5},   // albedo
                               {2, 0, 9},   {2, 9, 9},   {2, 18, 9},  {2, 27, 5}};  // radiance
constexpr uint32_t kWidthBits = 4;  // a column's width: 0 .. its field's bits (<= 14)
static_assert(kCompactSurfelRecordBytes == 18);

uint32_t field(const uint8_t* rec, const Column& c) {
  if (c.word == 0) {
    const auto lo = load_le<uint64_t>(rec);
    const uint64_t hi = load_le<uint16_t>(rec + 8);
    const uint64_t v =
        c.shift >= 64 ? hi >> (c.shift - 64) : (lo >> c.shift) | (c.shift == 0 ? 0 : hi << (64 - c.shift));
    return uint32_t(v & ((uint64_t(1) << c.bits) - 1));
  }
  return (load_le<uint32_t>(rec + (c.word == 1 ? 10 : 14)) >> c.shift) & ((1u << c.bits) - 1);
}

}  // namespace

void encode_surfel_section(std::span<const uint8_t> records, std::vector<uint8_t>& out) {
  const size_t n = records.size() / kCompactSurfelRecordBytes;
  if (n == 0) return;
  uint32_t lo[std::size(kColumns)], width[std::size(kColumns)];
  for (size_t c = 0; c < std::size(kColumns); ++c) {
    uint32_t a = ~0u, b = 0;
    for (size_t i = 0; i < n; ++i) {
      const uint32_t v = field(records.data() + i * kCompactSurfelRecordBytes, kColumns[c]);
      a = std::min(a, v);
      b = std::max(b, v);
    }
    lo[c] = a;
    width[c] = uint32_t(std::bit_width(b - a));
  }
  BitWriter w(out);
  for (size_t c = 0; c < std::size(kColumns); ++c) {
    w.put(lo[c], kColumns[c].bits);
    w.put(width[c], kWidthBits);
  }
  for (size_t c = 0; c < std::size(kColumns); ++c) {
    for (size_t i = 0; i < n; ++i) {
      w.put(field(records.data() + i * kCompactSurfelRecordBytes, kColumns[c]) - lo[c], width[c]);
    }
  }
  w.finish();
}

size_t decode_surfel_section(std::span<const uint8_t> bytes, size_t surfel_count, std::vector<uint8_t>& records,
                             const std::string& what) {
  records.assign(surfel_count * kCompactSurfelRecordBytes, 0);
  if (surfel_count == 0) return 0;
  auto corrupt = [&](const std::string& msg) { return CorruptionError(what + ": surfel section: " + msg); };
  uint64_t header_bits = 0;
  for (const Column& c : kColumns) header_bits += c.bits + kWidthBits;
  if (bytes.size() < (header_bits + 7) / 8) throw corrupt("its column header lies past the page's end");
  BitReader r(bytes);
  uint32_t lo[std::size(kColumns)], width[std::size(kColumns)];
  uint64_t bits = header_bits;
  for (size_t c = 0; c < std::size(kColumns); ++c) {
    lo[c] = r.get(kColumns[c].bits);
    width[c] = r.get(kWidthBits);
    if (width[c] > kColumns[c].bits) {
      throw corrupt("column " + std::to_string(c) + " is " + std::to_string(width[c]) + " bits wide, its field " +
                    std::to_string(kColumns[c].bits));
    }
    bits += uint64_t(surfel_count) * width[c];
  }
  const uint64_t size = (bits + 7) / 8;
  if (size > bytes.size()) {
    throw corrupt(std::to_string(surfel_count) + " surfels need " + std::to_string(size) + " bytes, " +
                  std::to_string(bytes.size()) + " remain");
  }
  // Surfel by surfel, each record assembled in registers and stored once:
  // column c's values start at bit start[c] of the section.
  uint64_t start[std::size(kColumns)];
  uint64_t at = header_bits;
  for (size_t c = 0; c < std::size(kColumns); ++c) {
    start[c] = at;
    at += uint64_t(surfel_count) * width[c];
  }
  const uint8_t* data = bytes.data();
  auto get = [&](uint64_t bit, uint32_t w) -> uint32_t {
    if (w == 0) return 0;
    // Up to 8 bytes from bit / 8, never past the section (w <= 14: the
    // value lies in the first 3); a whole word where the section has one.
    const uint64_t byte = bit / 8;
    uint64_t word = 0;
    if (byte + 8 <= size) {
      word = load_le<uint64_t>(data + byte);
    } else {
      uint8_t buf[8] = {};
      std::memcpy(buf, data + byte, size_t(size - byte));
      word = load_le<uint64_t>(buf);
    }
    return uint32_t((word >> (bit % 8)) & ((uint64_t(1) << w) - 1));
  };
  for (size_t i = 0; i < surfel_count; ++i) {
    uint32_t v[std::size(kColumns)];
    for (size_t c = 0; c < std::size(kColumns); ++c) {
      v[c] = lo[c] + get(start[c] + i * width[c], width[c]);
      if (v[c] >> kColumns[c].bits) {
        throw corrupt("surfel " + std::to_string(i) + "'s column " + std::to_string(c) + " is past its field");
      }
    }
    uint8_t* rec = records.data() + i * kCompactSurfelRecordBytes;
    uint64_t lo64 = 0, hi16 = 0;
    for (size_t c = 0; c < 7; ++c) {
      const uint32_t sh = kColumns[c].shift;
      if (sh >= 64) {
        hi16 |= uint64_t(v[c]) << (sh - 64);
      } else {
        lo64 |= uint64_t(v[c]) << sh;
        if (sh + kColumns[c].bits > 64) hi16 |= uint64_t(v[c]) >> (64 - sh);
      }
    }
    store_le<uint64_t>(rec, lo64);
    store_le<uint16_t>(rec + 8, uint16_t(hi16));
    store_le<uint32_t>(rec + 10, v[7] | v[8] << 9 | v[9] << 18 | v[10] << 27);
    store_le<uint32_t>(rec + 14, v[11] | v[12] << 9 | v[13] << 18 | v[14] << 27);
  }
  const auto pad = uint32_t((8 - bits % 8) % 8);
  if (pad > 0 && (bytes[size - 1] >> (8 - pad)) != 0) throw corrupt("padding bits are not zero");
  return size_t(size);
}

}  // namespace pbgi::storage
