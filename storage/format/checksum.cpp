#include "storage/format/checksum.h"

#include <xxhash.h>

#include <cstdio>

namespace pbgi::storage {

uint64_t checksum64(const void* data, size_t size) { return XXH3_64bits(data, size); }

std::string checksum_hex(uint64_t c) {
  char buf[19];
  std::snprintf(buf, sizeof buf, "0x%016llx", static_cast<unsigned long long>(c));
  return buf;
}

}  // namespace pbgi::storage
