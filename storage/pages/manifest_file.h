// manifest.pbgm: the page set's description, framed by
// storage/format/manifest_frame.h. Body layout (V1) in FORMAT.md.
#pragma once

#include "storage/pages/page_set.h"

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

namespace pbgi::storage {

std::vector<uint8_t> encode_manifest(const Manifest& m);

// Verifies frame and body: known versions and codec, consistent counts, page
// table within stats.file_bytes, root inside the page table.
// Throws CorruptionError / VersionError naming `path`.
Manifest decode_manifest(std::span<const uint8_t> file, const std::string& path);

// Reads and decodes `path`; NotFound if it does not exist, IoError.
Manifest read_manifest(const std::filesystem::path& path);

}  // namespace pbgi::storage
