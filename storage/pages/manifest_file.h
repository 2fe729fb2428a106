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

// Writes the manifest version manifest_format_of(m) (FORMAT.md).
std::vector<uint8_t> encode_manifest(const Manifest& m);

// The manifest version encode_manifest writes for `m`: V5 with V8-V11
// pages; for older page formats V4 for a leaf format other than relative,
// else V3 exactly when it declares glossy radiance, else V2.
uint32_t manifest_format_of(const Manifest& m);

// Verifies frame and body: known versions and codec, consistent counts, page
// table within stats.file_bytes, root inside the page table.
// Throws CorruptionError / VersionError naming `path`.
Manifest decode_manifest(std::span<const uint8_t> file, const std::string& path);

// Reads and decodes `path`; NotFound if it does not exist, IoError.
Manifest read_manifest(const std::filesystem::path& path);

}  // namespace pbgi::storage
