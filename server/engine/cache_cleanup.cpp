#include "server/engine/cache_cleanup.h"

#include "storage/pages/cache_files.h"

#include <spdlog/spdlog.h>

#include <system_error>

namespace fs = std::filesystem;

namespace pbgi {

size_t clean_cache_directory(const fs::path& cache_dir) {
  size_t removed = storage::remove_stale_temporaries(cache_dir);
  std::error_code ec;
  for (fs::directory_iterator it(cache_dir, ec), end; !ec && it != end; it.increment(ec)) {
    if (it->path().filename().string().find(kCorruptPageSetSuffix) == std::string::npos) continue;
    std::error_code rm;
    fs::remove_all(it->path(), rm);
    if (rm) {
      spdlog::warn("cannot remove the corrupt page set {}: {}", it->path().string(), rm.message());
    } else {
      ++removed;
    }
  }
  if (removed > 0) spdlog::info("removed {} leftovers of earlier runs from {}", removed, cache_dir.string());
  return removed;
}

}  // namespace pbgi
