// Sequential little-endian writer and bounds-checked reader over byte
// buffers. The reader never reads past its end: running out of bytes means
// the stored data is damaged, so it throws CorruptionError naming the file
// (or page) and the offset where the field should have been.
#pragma once

#include "storage/format/byte_order.h"

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace pbgi::storage {

class ByteWriter {
 public:
  explicit ByteWriter(std::vector<uint8_t>& out) : out_(out) {}

  template <typename T>
  void put(T v) {
    const size_t at = out_.size();
    out_.resize(at + sizeof(T));
    store_le<T>(out_.data() + at, v);
  }
  void put_bytes(std::span<const uint8_t> bytes) { out_.insert(out_.end(), bytes.begin(), bytes.end()); }
  // u32 length, then the bytes.
  void put_string(std::string_view s);
  size_t size() const { return out_.size(); }

 private:
  std::vector<uint8_t>& out_;
};

class ByteReader {
 public:
  // `what` names the data in errors ("/x/manifest.pbgm"); `base_offset` is
  // the file offset of bytes[0], so errors report file offsets.
  ByteReader(std::span<const uint8_t> bytes, std::string what, uint64_t base_offset = 0)
      : bytes_(bytes), what_(std::move(what)), base_(base_offset) {}

  template <typename T>
  T get(const char* field) {
    require(sizeof(T), field);
    const T v = load_le<T>(bytes_.data() + pos_);
    pos_ += sizeof(T);
    return v;
  }
  std::span<const uint8_t> get_bytes(size_t n, const char* field);
  // Reads a u32 length and that many bytes; refuses lengths above max_length.
  std::string get_string(const char* field, uint32_t max_length);

  size_t position() const { return pos_; }
  size_t remaining() const { return bytes_.size() - pos_; }
  uint64_t file_offset() const { return base_ + pos_; }
  const std::string& what() const { return what_; }
  // Throws CorruptionError unless every byte was consumed.
  void expect_end() const;

 private:
  void require(size_t n, const char* field) const;

  std::span<const uint8_t> bytes_;
  std::string what_;
  uint64_t base_ = 0;
  size_t pos_ = 0;
};

}  // namespace pbgi::storage
