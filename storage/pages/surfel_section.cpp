#include "storage/pages/surfel_section.h"

#include "common/errors.h"
#include "storage/codecs/bit_packing.h"
#include "storage/format/byte_order.h"
#include "storage/format/format_version.h"
#include "storage/tree/leaf_format.h"

#include <algorithm>
#include <bit>
#include <cmath>
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
constexpr size_t kColumnCount = std::size(kColumns);
constexpr uint32_t kWidthBits = 4;  // a column's width: 0 .. its field's bits (<= 14)
static_assert(kCompactSurfelRecordBytes == 18);

// V10/V11: positions (columns 0-2) whose codes all end in `shift` one bits
// (a grid 8191 + 2^shift j, page_records.h position_grid_shift), shift <=
// 4 the largest for which every code of the page does, stored in 3 bits
// first; each code is stored as code >> shift in 14 - shift bits.
constexpr size_t kRadiusColumn = 5;
constexpr uint32_t kShiftBits = 3, kMaxShift = 4;
// V10/V11 radius: the difference to the prediction plus kRadiusBias, in
// 14 bits; the first surfel's code in full (13 bits) before its column.
constexpr uint32_t kRadiusMax = (1u << 13) - 1u, kRadiusBias = kRadiusMax, kResidualBits = 14;

uint32_t stored_bits(size_t c, bool v10, uint32_t shift) {
  if (v10 && c < 3) return kColumns[c].bits - shift;
  if (v10 && c == kRadiusColumn) return kResidualBits;
  return kColumns[c].bits;
}

// The radius code `prev` of a surfel in a leaf frame of radius prev_r,
// rescaled to a frame of radius r (exact IEEE arithmetic: writer and
// reader predict alike on any CPU).
uint32_t predict_radius(uint32_t prev, float prev_r, float r) {
  if (!(prev_r > 0.f) || !(r > 0.f) || prev_r == r) return prev;
  // Clamped before rounding: a ratio of extreme radii must not overflow.
  const double p = std::min(double(prev) * double(prev_r) / double(r), double(kRadiusMax));
  return uint32_t(std::lround(p));
}

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

// The frame radius of each of the n records' leaves.
std::vector<float> leaf_radius_of_records(std::span<const LeafRecord> leaves, size_t n) {
  std::vector<float> r;
  r.reserve(n);
  for (const LeafRecord& l : leaves) r.insert(r.end(), l.surfel_count, l.frame.radius);
  if (r.size() != n) {
    throw Error("internal: surfel section of " + std::to_string(n) + " records for leaves of " +
                std::to_string(r.size()) + " surfels");
  }
  return r;
}

}  // namespace

void encode_surfel_section(std::span<const uint8_t> records, std::span<const LeafRecord> leaves, uint32_t format,
                           std::vector<uint8_t>& out) {
  const size_t n = records.size() / kCompactSurfelRecordBytes;
  if (n == 0) return;
  const bool v10 = page_format_has_small_frame(format);
  const std::vector<float> radius = v10 ? leaf_radius_of_records(leaves, n) : std::vector<float>{};
  auto rec = [&](size_t i) { return records.data() + i * kCompactSurfelRecordBytes; };
  uint32_t shift = 0;
  if (v10) {
    shift = kMaxShift;
    for (size_t i = 0; i < n; ++i) {
      for (size_t c = 0; c < 3; ++c) {
        shift = std::min(shift, uint32_t(std::countr_one(field(rec(i), kColumns[c]))));
      }
    }
  }
  // The value column c stores for record i (V10's radius column: i >= 1).
  auto stored = [&](size_t c, size_t i) -> uint32_t {
    const uint32_t v = field(rec(i), kColumns[c]);
    if (!v10) return v;
    if (c < 3) return v >> shift;
    if (c == kRadiusColumn) {
      const uint32_t p = predict_radius(field(rec(i - 1), kColumns[c]), radius[i - 1], radius[i]);
      return v + kRadiusBias - p;
    }
    return v;
  };
  auto first = [&](size_t c) { return v10 && c == kRadiusColumn ? size_t(1) : size_t(0); };
  uint32_t lo[kColumnCount], width[kColumnCount];
  for (size_t c = 0; c < kColumnCount; ++c) {
    uint32_t a = ~0u, b = 0;
    for (size_t i = first(c); i < n; ++i) {
      const uint32_t v = stored(c, i);
      a = std::min(a, v);
      b = std::max(b, v);
    }
    if (a > b) a = b = 0;  // V10's radius column of a single surfel
    lo[c] = a;
    width[c] = uint32_t(std::bit_width(b - a));
  }
  BitWriter w(out);
  if (v10) w.put(shift, kShiftBits);
  for (size_t c = 0; c < kColumnCount; ++c) {
    if (first(c) == 1) w.put(field(rec(0), kColumns[c]), kColumns[c].bits);
    w.put(lo[c], stored_bits(c, v10, shift));
    w.put(width[c], kWidthBits);
  }
  for (size_t c = 0; c < kColumnCount; ++c) {
    for (size_t i = first(c); i < n; ++i) w.put(stored(c, i) - lo[c], width[c]);
  }
  w.finish();
}

size_t decode_surfel_section(std::span<const uint8_t> bytes, std::span<const LeafRecord> leaves, uint32_t format,
                             std::vector<uint8_t>& records, const std::string& what) {
  size_t surfel_count = 0;
  for (const LeafRecord& l : leaves) surfel_count += l.surfel_count;
  records.assign(surfel_count * kCompactSurfelRecordBytes, 0);
  if (surfel_count == 0) return 0;
  const bool v10 = page_format_has_small_frame(format);
  auto corrupt = [&](const std::string& msg) { return CorruptionError(what + ": surfel section: " + msg); };
  if (bytes.empty()) throw corrupt("its column header lies past the page's end");
  BitReader r(bytes);
  const uint32_t shift = v10 ? r.get(kShiftBits) : 0;
  if (shift > kMaxShift) throw corrupt("positions shifted by " + std::to_string(shift) + " bits");
  uint64_t header_bits = v10 ? kShiftBits + kColumns[kRadiusColumn].bits : 0;
  for (size_t c = 0; c < kColumnCount; ++c) header_bits += stored_bits(c, v10, shift) + kWidthBits;
  if (bytes.size() < (header_bits + 7) / 8) throw corrupt("its column header lies past the page's end");
  uint32_t lo[kColumnCount], width[kColumnCount], count[kColumnCount];
  uint32_t first_radius = 0;
  uint64_t bits = header_bits;
  for (size_t c = 0; c < kColumnCount; ++c) {
    if (v10 && c == kRadiusColumn) first_radius = r.get(kColumns[c].bits);
    lo[c] = r.get(stored_bits(c, v10, shift));
    width[c] = r.get(kWidthBits);
    if (width[c] > stored_bits(c, v10, shift)) {
      throw corrupt("column " + std::to_string(c) + " is " + std::to_string(width[c]) + " bits wide, its field " +
                    std::to_string(stored_bits(c, v10, shift)));
    }
    count[c] = uint32_t(surfel_count) - (v10 && c == kRadiusColumn ? 1u : 0u);
    bits += uint64_t(count[c]) * width[c];
  }
  const uint64_t size = (bits + 7) / 8;
  if (size > bytes.size()) {
    throw corrupt(std::to_string(surfel_count) + " surfels need " + std::to_string(size) + " bytes, " +
                  std::to_string(bytes.size()) + " remain");
  }
  // Surfel by surfel, each record assembled in registers and stored once:
  // column c's values start at bit start[c] of the section (V10's radius
  // column at its second surfel).
  uint64_t start[kColumnCount];
  uint64_t at = header_bits;
  for (size_t c = 0; c < kColumnCount; ++c) {
    start[c] = at;
    at += uint64_t(count[c]) * width[c];
  }
  if (v10) start[kRadiusColumn] -= width[kRadiusColumn];
  // The section with 8 zero bytes after it, so that every value is one
  // 8-byte load however close to the section's end (w <= 14: a value lies
  // in the 3 bytes from bit / 8); and each column's mask and largest
  // value, so that the loop below is loads, shifts and one compare a value
  // (it decodes every surfel of every page a cache miss loads).
  thread_local std::vector<uint8_t> padded;
  padded.assign(bytes.begin(), bytes.begin() + ptrdiff_t(size));
  padded.resize(size_t(size) + 8, 0);
  const uint8_t* data = padded.data();
  uint64_t mask[kColumnCount];
  uint32_t largest[kColumnCount];
  for (size_t c = 0; c < kColumnCount; ++c) {
    mask[c] = (uint64_t(1) << width[c]) - 1;
    largest[c] = (1u << stored_bits(c, v10, shift)) - 1u;
  }
  auto get = [&](uint64_t bit, size_t c) -> uint32_t {
    return uint32_t((load_le<uint64_t>(data + bit / 8) >> (bit % 8)) & mask[c]);
  };
  // V10: the leaf of the current surfel (its frame radius), and the
  // previous surfel's radius code and frame radius.
  size_t leaf = 0;
  uint32_t left_in_leaf = 0;
  float leaf_r = 0.f, prev_r = 0.f;
  uint32_t prev_code = 0;
  for (size_t i = 0; i < surfel_count; ++i) {
    uint32_t v[kColumnCount];
    bool past = false;
    for (size_t c = 0; c < kColumnCount; ++c) {
      v[c] = lo[c] + get(start[c] + i * width[c], c);
      past |= v[c] > largest[c];
    }
    if (v10 && i == 0) v[kRadiusColumn] = kRadiusBias;  // the first code, read above; no value of its own
    if (past) {
      for (size_t c = 0; c < kColumnCount; ++c) {
        if (v[c] > largest[c]) {
          throw corrupt("surfel " + std::to_string(i) + "'s column " + std::to_string(c) + " is past its field");
        }
      }
    }
    if (v10) {
      for (size_t c = 0; c < 3; ++c) v[c] = v[c] << shift | ((1u << shift) - 1u);
      while (left_in_leaf == 0) {  // leaves count >= 1 surfel (leaf section)
        leaf_r = leaves[leaf].frame.radius;
        left_in_leaf = leaves[leaf++].surfel_count;
      }
      --left_in_leaf;
      uint32_t code = first_radius;
      if (i > 0) {
        const int64_t x =
            int64_t(predict_radius(prev_code, prev_r, leaf_r)) + int64_t(v[kRadiusColumn]) - int64_t(kRadiusBias);
        if (x < 0 || x > int64_t(kRadiusMax)) {
          throw corrupt("surfel " + std::to_string(i) + "'s radius is past its field");
        }
        code = uint32_t(x);
      }
      v[kRadiusColumn] = prev_code = code;
      prev_r = leaf_r;
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
