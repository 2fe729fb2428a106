// The checksum of every pbgi on-disk block: XXH3-64 (seed 0) over the bytes
// it protects. Fast enough (> 10 GB/s) to verify every page on every read.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

namespace pbgi::storage {

uint64_t checksum64(const void* data, size_t size);
// The same seeded with `seed` (V10/V11 pages: their page id).
uint64_t checksum64(const void* data, size_t size, uint64_t seed);

// checksum64 of bytes that arrive in pieces (a file streamed through a
// buffer): digest() equals checksum64 over all of them concatenated.
// Not copyable; one stream per thread.
class Checksum64Stream {
 public:
  Checksum64Stream();
  ~Checksum64Stream();
  Checksum64Stream(const Checksum64Stream&) = delete;
  Checksum64Stream& operator=(const Checksum64Stream&) = delete;

  void update(const void* data, size_t size);
  uint64_t digest() const;

 private:
  void* state_;  // XXH3_state_t, kept out of this header
};

// "0x%016x": how checksums appear in error messages.
std::string checksum_hex(uint64_t c);

// The bytes of a block that ends with the XXH3-64 of everything before it,
// without that trailer. CorruptionError, prefixed with `what`, when the
// block is shorter than `min_bytes` (trailer included) or the checksum
// does not match (naming its offset, expected and found values).
std::span<const uint8_t> checked_body(std::span<const uint8_t> block, size_t min_bytes, const std::string& what);

}  // namespace pbgi::storage
