#include "server/scene/asset_roots.h"

#include "common/errors.h"

#include <fmt/format.h>

#include <algorithm>
#include <system_error>

namespace fs = std::filesystem;

namespace pbgi {

AssetRoots::AssetRoots(const std::vector<fs::path>& roots) : confined_(true) {
  for (const fs::path& root : roots) {
    std::error_code ec;
    fs::path canonical = fs::canonical(root, ec);
    if (ec) throw IoError(fmt::format("scene root '{}': {}", root.string(), ec.message()));
    if (!fs::is_directory(canonical, ec)) {
      throw IoError(fmt::format("scene root '{}' is not a directory", root.string()));
    }
    roots_.push_back(std::move(canonical));
  }
}

bool AssetRoots::contains(const fs::path& canonical) const {
  for (const fs::path& root : roots_) {
    // Component-wise prefix test: "/scenes-private" is not inside "/scenes".
    auto [root_end, path_it] = std::mismatch(root.begin(), root.end(), canonical.begin(), canonical.end());
    if (root_end == root.end() && path_it != canonical.end()) return true;
  }
  return false;
}

bool AssetRoots::allows(const fs::path& path) const {
  if (!confined_) return true;
  if (path.empty()) return false;
  std::error_code ec;
  // weakly_canonical follows the symlinks of the existing prefix and
  // normalizes the rest.
  const fs::path resolved = fs::weakly_canonical(path, ec);
  return !ec && contains(resolved);
}

void AssetRoots::check(const fs::path& path, const std::string& what) const {
  if (!allows(path)) throw PermissionDenied(fmt::format("{} is outside the scene roots", what));
}

}  // namespace pbgi
