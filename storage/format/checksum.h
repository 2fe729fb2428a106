// The checksum of every pbgi on-disk block: XXH3-64 (seed 0) over the bytes
// it protects. Fast enough (> 10 GB/s) to verify every page on every read.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

namespace pbgi::storage {

uint64_t checksum64(const void* data, size_t size);

// "0x%016x": how checksums appear in error messages.
std::string checksum_hex(uint64_t c);

}  // namespace pbgi::storage
