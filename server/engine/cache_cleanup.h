// What earlier daemons leave in a cache directory and the next start
// removes: staging directories and temporary files of processes that no
// longer run (storage/pages/cache_files.h), and page sets moved aside as
// corrupt ("<key>.corrupt-<time>", kept for inspection until then).
#pragma once

#include <cstddef>
#include <filesystem>
#include <string_view>

namespace pbgi {

// A page set that fails verification is renamed to <dir> + this + a time.
inline constexpr std::string_view kCorruptPageSetSuffix = ".corrupt-";

// Removes the leftovers described above from `cache_dir` (not recursive:
// the chunk store cleans its own directory). Errors are logged, not
// thrown (a read-only cache volume is fine). Returns how many were removed.
size_t clean_cache_directory(const std::filesystem::path& cache_dir);

}  // namespace pbgi
