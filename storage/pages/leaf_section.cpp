#include "storage/pages/leaf_section.h"

#include "common/errors.h"
#include "storage/codecs/bit_packing.h"

#include <algorithm>
#include <bit>
#include <cmath>

namespace pbgi::storage {

namespace {

constexpr size_t kWidthBytes = 3;
constexpr uint32_t kExponentBits = 8;   // the first leaf's e + 128
constexpr uint32_t kCenterBits = 24;    // the first leaf's k (and every k in full)
constexpr uint32_t kMaxDeltaBits = 25;  // zigzag differences of the centre
constexpr uint32_t kMaxExponentDeltaBits = 15;
constexpr uint32_t kMaxRadiusBits = 12;
constexpr uint32_t kMaxCountBits = 12;
constexpr uint8_t kAbsoluteCentres = 0x10;  // byte 0, bit 4
constexpr int kExponentBias = 128;

uint64_t zigzag(int64_t v) { return (uint64_t(v) << 1) ^ uint64_t(v >> 63); }
int64_t unzigzag(uint64_t z) { return int64_t(z >> 1) ^ -int64_t(z & 1); }
uint32_t width(uint64_t v) { return uint32_t(std::bit_width(v)); }

// k on leaf i's grid of the previous leaf's centre coordinate c: floor(c
// 2^-e) in double (exact: a float times a power of two; below 2^150).
double base_of(float previous, int e) { return std::floor(double(previous) * std::ldexp(1.0, -e)); }

void put(BitWriter& w, uint64_t v, uint32_t bits) {
  // BitWriter takes up to 32 bits at once.
  if (bits > 16) {
    w.put(uint32_t(v & 0xffffu), 16);
    w.put(uint32_t(v >> 16), bits - 16);
  } else {
    w.put(uint32_t(v), bits);
  }
}
uint64_t get(BitReader& r, uint32_t bits) {
  if (bits > 16) {
    const uint64_t lo = r.get(16);
    return lo | uint64_t(r.get(bits - 16)) << 16;
  }
  return r.get(bits);
}

}  // namespace

void encode_leaf_section(std::span<const LeafRecord> leaves, std::vector<uint8_t>& out) {
  if (leaves.empty()) return;
  std::vector<RoundedFrame> r(leaves.size());
  uint32_t m_bits = 0, count_bits = 0, e_bits = 0, delta_bits = 0;
  bool absolute = false;
  for (size_t i = 0; i < leaves.size(); ++i) {
    const LeafRecord& l = leaves[i];
    if (!to_rounded_frame(l.frame, r[i]) || l.surfel_count < 1 || l.surfel_count > kMaxCompactLeafSurfels) {
      throw Error("internal: leaf " + std::to_string(i) + " of a page has a frame that is not rounded or " +
                  std::to_string(l.surfel_count) + " surfels");
    }
    m_bits = std::max(m_bits, width(r[i].m));
    count_bits = std::max(count_bits, width(l.surfel_count - 1));
    if (i == 0) continue;
    e_bits = std::max(e_bits, width(zigzag(r[i].exponent - r[i - 1].exponent)));
    for (int a = 0; a < 3; ++a) {
      const double delta = double(r[i].k[a]) - base_of(leaves[i - 1].frame.center[a], r[i].exponent);
      if (std::abs(delta) >= double(1u << (kMaxDeltaBits - 1))) {
        absolute = true;
      } else {
        delta_bits = std::max(delta_bits, width(zigzag(int64_t(delta))));
      }
    }
  }
  if (absolute) delta_bits = kCenterBits;
  out.push_back(uint8_t(e_bits | (absolute ? kAbsoluteCentres : 0u)));
  out.push_back(uint8_t(delta_bits));
  out.push_back(uint8_t(m_bits | count_bits << 4));
  BitWriter w(out);
  for (size_t i = 0; i < leaves.size(); ++i) {
    if (i == 0) {
      w.put(uint32_t(r[0].exponent + kExponentBias), kExponentBits);
      for (const auto k : r[0].k) put(w, uint32_t(k) & 0xffffffu, kCenterBits);
    } else {
      w.put(uint32_t(zigzag(r[i].exponent - r[i - 1].exponent)), e_bits);
      for (int a = 0; a < 3; ++a) {
        if (absolute) {
          put(w, uint32_t(r[i].k[a]) & 0xffffffu, kCenterBits);
        } else {
          const double delta = double(r[i].k[a]) - base_of(leaves[i - 1].frame.center[a], r[i].exponent);
          put(w, zigzag(int64_t(delta)), delta_bits);
        }
      }
    }
    w.put(r[i].m, m_bits);
    w.put(leaves[i].surfel_count - 1, count_bits);
  }
  w.finish();
}

size_t decode_leaf_section(std::span<const uint8_t> bytes, size_t leaf_count, std::vector<LeafRecord>& out,
                           const std::string& what) {
  out.clear();
  if (leaf_count == 0) return 0;
  auto corrupt = [&](const std::string& msg) { return CorruptionError(what + ": leaf section: " + msg); };
  if (bytes.size() < kWidthBytes) throw corrupt("its widths lie past the page's end");
  const uint32_t e_bits = bytes[0] & 0x0fu;
  const bool absolute = (bytes[0] & kAbsoluteCentres) != 0;
  const uint32_t delta_bits = bytes[1];
  const uint32_t m_bits = bytes[2] & 0x0fu, count_bits = bytes[2] >> 4;
  if ((bytes[0] & 0xe0u) != 0 || e_bits > kMaxExponentDeltaBits || delta_bits > kMaxDeltaBits ||
      (absolute && delta_bits != kCenterBits) || m_bits > kMaxRadiusBits || count_bits > kMaxCountBits) {
    throw corrupt("widths " + std::to_string(bytes[0]) + ", " + std::to_string(bytes[1]) + ", " +
                  std::to_string(bytes[2]) + " are out of range");
  }
  const uint64_t bits = kExponentBits + 3 * kCenterBits + m_bits + count_bits +
                        uint64_t(leaf_count - 1) * (e_bits + 3 * delta_bits + m_bits + count_bits);
  const uint64_t size = kWidthBytes + (bits + 7) / 8;
  if (size > bytes.size()) {
    throw corrupt(std::to_string(leaf_count) + " leaves need " + std::to_string(size) + " bytes, " +
                  std::to_string(bytes.size()) + " remain");
  }
  out.resize(leaf_count);
  BitReader r(bytes.subspan(kWidthBytes, size - kWidthBytes));
  RoundedFrame f;
  for (size_t i = 0; i < leaf_count; ++i) {
    auto bad = [&](const std::string& field) {
      return corrupt("leaf " + std::to_string(i) + " has " + field + " out of range");
    };
    if (i == 0) {
      f.exponent = int(r.get(kExponentBits)) - kExponentBias;
    } else {
      f.exponent += int(unzigzag(r.get(e_bits)));
    }
    if (f.exponent < kMinFrameExponent || f.exponent > kMaxFrameExponent) throw bad("an exponent");
    for (int a = 0; a < 3; ++a) {
      double k;
      if (i == 0 || absolute) {
        const auto u = uint32_t(get(r, kCenterBits));
        k = double(int32_t(u ^ 0x800000u) - 0x800000);
      } else {
        k = base_of(out[i - 1].frame.center[a], f.exponent) + double(unzigzag(get(r, delta_bits)));
      }
      if (!(std::abs(k) <= double(kMaxRoundedFrameCenter))) throw bad("a centre");
      f.k[a] = int32_t(k);
    }
    f.m = r.get(m_bits);
    out[i].surfel_count = r.get(count_bits) + 1;
    if (out[i].surfel_count > kMaxCompactLeafSurfels) throw bad("a surfel count");
    out[i].frame = f.frame();
    const Imath::V3f& c = out[i].frame.center;
    if (!std::isfinite(c.x) || !std::isfinite(c.y) || !std::isfinite(c.z)) throw bad("a centre");
  }
  const auto pad_bits = size_t((8 - bits % 8) % 8);
  if (pad_bits > 0 && (bytes[size - 1] >> (8 - pad_bits)) != 0) throw corrupt("padding bits are not zero");
  return size_t(size);
}

}  // namespace pbgi::storage
