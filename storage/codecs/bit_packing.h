// Fixed-width bit packing of unsigned codes (LUT indices, scale codes).
// Codes are packed LSB-first into a little-endian byte stream: code i of
// width w occupies stream bits [i*w, (i+1)*w), bit k of the stream being
// bit (k % 8) of byte k / 8. The layout is therefore independent of the
// host byte order and of how many codes are written per call.
//
// Thread-safety: a BitWriter / BitReader is a cursor over one buffer; use
// one per thread.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace pbgi::storage {

// Bits needed to tell `count` values apart: ceil(log2(count)), 0 for count <= 1.
inline uint32_t bits_for_count(uint64_t count) {
  uint32_t b = 0;
  while (b < 64 && (uint64_t(1) << b) < count) ++b;
  return b;
}

// Bytes holding `count` codes of `bits` bits (the last byte zero-padded).
inline size_t packed_bytes(size_t count, uint32_t bits) { return (count * bits + 7) / 8; }

// Appends codes to a byte vector. The stream is flushed (padded to a whole
// byte) by finish(); the destructor does not flush.
class BitWriter {
 public:
  explicit BitWriter(std::vector<uint8_t>& out) : out_(out) {}
  // Appends the low `bits` bits of `code` (bits in 0..32; higher bits of
  // `code` must be 0).
  void put(uint32_t code, uint32_t bits) {
    acc_ |= uint64_t(code) << fill_;
    fill_ += bits;
    while (fill_ >= 8) {
      out_.push_back(uint8_t(acc_));
      acc_ >>= 8;
      fill_ -= 8;
    }
  }
  // Writes the pending bits, zero-padded to a byte boundary.
  void finish() {
    if (fill_ > 0) out_.push_back(uint8_t(acc_));
    acc_ = 0;
    fill_ = 0;
  }

 private:
  std::vector<uint8_t>& out_;
  uint64_t acc_ = 0;
  uint32_t fill_ = 0;
};

// Reads codes back. The caller checks the stream size first
// (packed_bytes()); reading past the end returns zero bits.
class BitReader {
 public:
  explicit BitReader(std::span<const uint8_t> in) : in_(in) {}
  uint32_t get(uint32_t bits) {
    while (fill_ < bits) {
      const uint64_t byte = pos_ < in_.size() ? in_[pos_] : 0;
      ++pos_;
      acc_ |= byte << fill_;
      fill_ += 8;
    }
    const uint32_t code = bits == 0 ? 0u : uint32_t(acc_ & ((uint64_t(1) << bits) - 1));
    acc_ >>= bits;
    fill_ -= bits;
    return code;
  }

 private:
  std::span<const uint8_t> in_;
  size_t pos_ = 0;
  uint64_t acc_ = 0;
  uint32_t fill_ = 0;
};

}  // namespace pbgi::storage
