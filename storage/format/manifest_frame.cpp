#include "storage/format/manifest_frame.h"

#include "common/errors.h"
#include "storage/format/byte_order.h"
#include "storage/format/checksum.h"
#include "storage/format/known_versions.h"

#include <algorithm>
#include <cstdio>

namespace pbgi::storage {

namespace {
std::string hex32(uint32_t v) {
  char buf[11];
  std::snprintf(buf, sizeof buf, "0x%08x", v);
  return buf;
}
}  // namespace

std::vector<uint8_t> frame_manifest(std::span<const uint8_t> body, uint32_t version) {
  std::vector<uint8_t> out(kManifestHeaderBytes + body.size() + kManifestTrailerBytes);
  store_le<uint32_t>(out.data() + 0, kManifestMagic);
  store_le<uint32_t>(out.data() + 4, version);
  store_le<uint64_t>(out.data() + 8, body.size());
  std::copy(body.begin(), body.end(), out.begin() + kManifestHeaderBytes);
  const size_t covered = kManifestHeaderBytes + body.size();
  store_le<uint64_t>(out.data() + covered, checksum64(out.data(), covered));
  return out;
}

ManifestBody unframe_manifest(std::span<const uint8_t> file, const std::string& path) {
  if (file.size() < kManifestHeaderBytes + kManifestTrailerBytes) {
    throw CorruptionError(path + ": " + std::to_string(file.size()) +
                          " bytes, too small for a manifest (at least " +
                          std::to_string(kManifestHeaderBytes + kManifestTrailerBytes) + ")");
  }
  const uint32_t magic = load_le<uint32_t>(file.data());
  if (magic != kManifestMagic) {
    throw CorruptionError(path + ": bad magic at offset 0: expected " +
                          hex32(kManifestMagic) + " ('PBGM'), found " + hex32(magic));
  }
  const uint32_t version = load_le<uint32_t>(file.data() + 4);
  if (!is_known_manifest_format(version)) {
    throw VersionError(path + ": manifest format version " + std::to_string(version) +
                       " is not supported by this build (reads " + known_versions(is_known_manifest_format) + ")");
  }
  const uint64_t body_bytes = load_le<uint64_t>(file.data() + 8);
  const uint64_t expected_size = kManifestHeaderBytes + body_bytes + kManifestTrailerBytes;
  if (body_bytes > file.size() || expected_size != file.size()) {
    throw CorruptionError(path + ": size mismatch at offset 8: header says body of " +
                          std::to_string(body_bytes) + " bytes, file has " +
                          std::to_string(file.size()) + " bytes");
  }
  const size_t covered = kManifestHeaderBytes + body_bytes;
  const uint64_t expected = load_le<uint64_t>(file.data() + covered);
  const uint64_t found = checksum64(file.data(), covered);
  if (expected != found) {
    throw CorruptionError(path + ": checksum mismatch at offset " + std::to_string(covered) +
                          ": expected " + checksum_hex(expected) + ", found " +
                          checksum_hex(found));
  }
  return {version, file.subspan(kManifestHeaderBytes, body_bytes)};
}

}  // namespace pbgi::storage
