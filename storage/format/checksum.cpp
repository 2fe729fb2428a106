#include "storage/format/checksum.h"

#include "common/errors.h"
#include "storage/format/byte_order.h"

#include <xxhash.h>

#include <algorithm>
#include <new>

#include <cstdio>

namespace pbgi::storage {

uint64_t checksum64(const void* data, size_t size) { return XXH3_64bits(data, size); }
uint64_t checksum64(const void* data, size_t size, uint64_t seed) { return XXH3_64bits_withSeed(data, size, seed); }

Checksum64Stream::Checksum64Stream() : state_(XXH3_createState()) {
  if (!state_) throw std::bad_alloc();
  XXH3_64bits_reset(static_cast<XXH3_state_t*>(state_));
}

Checksum64Stream::~Checksum64Stream() { XXH3_freeState(static_cast<XXH3_state_t*>(state_)); }

void Checksum64Stream::update(const void* data, size_t size) {
  if (size > 0) XXH3_64bits_update(static_cast<XXH3_state_t*>(state_), data, size);
}

uint64_t Checksum64Stream::digest() const { return XXH3_64bits_digest(static_cast<const XXH3_state_t*>(state_)); }

std::string checksum_hex(uint64_t c) {
  char buf[19];
  std::snprintf(buf, sizeof buf, "0x%016llx", static_cast<unsigned long long>(c));
  return buf;
}

std::span<const uint8_t> checked_body(std::span<const uint8_t> block, size_t min_bytes, const std::string& what) {
  if (block.size() < std::max<size_t>(min_bytes, 8)) {
    throw CorruptionError(what + ": only " + std::to_string(block.size()) + " bytes");
  }
  const size_t body = block.size() - 8;
  const uint64_t stored = load_le<uint64_t>(block.data() + body), found = checksum64(block.data(), body);
  if (stored != found) {
    throw CorruptionError(what + ": checksum mismatch at offset " + std::to_string(body) + ": expected " +
                          checksum_hex(stored) + ", found " + checksum_hex(found));
  }
  return block.first(body);
}

}  // namespace pbgi::storage
