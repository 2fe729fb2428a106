// The wire's packed float32 arrays (GatherRequest.positions, RenderTile
// AOVs...) to and from vectors; little-endian hosts only, like the daemon.
#pragma once

#include "common/errors.h"

#include <Imath/ImathVec.h>

#include <cstring>
#include <string>
#include <vector>

namespace pbgi::client {

inline std::string pack_vec3(const std::vector<Imath::V3f>& values) {
  static_assert(sizeof(Imath::V3f) == 3 * sizeof(float));
  return std::string(reinterpret_cast<const char*>(values.data()),
                     values.size() * sizeof(Imath::V3f));
}

// Throws CorruptionError naming `field` unless `bytes` holds exactly
// `expected_count` floats.
inline std::vector<float> unpack_floats(const std::string& bytes, size_t expected_count,
                                        const char* field) {
  if (bytes.size() != expected_count * sizeof(float)) {
    throw CorruptionError(std::string("server response field ") + field + " has " +
                          std::to_string(bytes.size()) + " bytes, expected " +
                          std::to_string(expected_count * sizeof(float)));
  }
  std::vector<float> out(expected_count);
  if (expected_count) std::memcpy(out.data(), bytes.data(), bytes.size());
  return out;
}

}  // namespace pbgi::client
