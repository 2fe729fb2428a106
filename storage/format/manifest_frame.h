// The frame of manifest.pbgm: a 16-byte header (magic 'PBGM', manifest
// format version, body size), the body (written by storage/pages), and an
// 8-byte trailer with the XXH3-64 checksum of header + body.
//
// Errors: unframe_manifest() throws VersionError for an unknown version
// (checked before the checksum: another version may checksum differently),
// CorruptionError for a bad magic, size or checksum, naming the file and the
// expected and found values.
#pragma once

#include "storage/format/format_version.h"

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace pbgi::storage {

inline constexpr size_t kManifestHeaderBytes = 16;
inline constexpr size_t kManifestTrailerBytes = 8;

std::vector<uint8_t> frame_manifest(std::span<const uint8_t> body,
                                    uint32_t version = kManifestFormatCurrent);

struct ManifestBody {
  uint32_t version = 0;
  std::span<const uint8_t> body;  // points into the file bytes
  static constexpr uint64_t kBodyOffset = kManifestHeaderBytes;
};

ManifestBody unframe_manifest(std::span<const uint8_t> file, const std::string& path);

}  // namespace pbgi::storage
