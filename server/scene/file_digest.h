// Content digests of the files a scene is read from (a .vdb or .drc scene,
// the layers and assets an ingested scene depends on, the VDB files of its
// volumes): the keys under which their ingests are cached and checked.
#pragma once

#include <filesystem>
#include <optional>
#include <string>

namespace pbgi {

// XXH64 (seed 0) of the file's bytes, as 16 lowercase hex digits. nullopt
// when the file cannot be opened or a read fails part-way (a directory, an
// I/O error): never the digest of part of a file. Callers decide what a
// missing digest means (a cache entry that no longer holds, a SceneError).
// Thread-safe; reads the file in 1 MiB blocks.
std::optional<std::string> file_digest(const std::filesystem::path& path);

}  // namespace pbgi
