// Hand-made scene streams for the ingest tests: one SceneChunk as the USD
// reader frames it (u32 little-endian length + the serialized message).
#pragma once

#include "pbgi/v1/scene.pb.h"

#include <cstdint>
#include <string>

namespace pbgi::test {

inline std::string framed(const pbgi::v1::SceneChunk& chunk) {
  const std::string body = chunk.SerializeAsString();
  const uint32_t n = static_cast<uint32_t>(body.size());
  const char length[4] = {char(n & 0xff), char(n >> 8 & 0xff), char(n >> 16 & 0xff), char(n >> 24 & 0xff)};
  return std::string(length, 4) + body;
}

}  // namespace pbgi::test
