#include "server/service/scene_roots.h"

#include <fmt/format.h>

#include <algorithm>
#include <system_error>

namespace fs = std::filesystem;

namespace pbgi::service {
namespace {

std::string join_paths(const std::vector<fs::path>& paths) {
  std::string out;
  for (const fs::path& p : paths) {
    if (!out.empty()) out += ", ";
    out += p.string();
  }
  return out;
}

}  // namespace

SceneRoots::SceneRoots(const std::vector<fs::path>& roots) {
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

bool SceneRoots::contains(const fs::path& canonical) const {
  for (const fs::path& root : roots_) {
    // Component-wise prefix test: "/scenes-private" is not inside "/scenes".
    auto [root_end, path_it] =
        std::mismatch(root.begin(), root.end(), canonical.begin(), canonical.end());
    if (root_end == root.end() && path_it != canonical.end()) return true;
  }
  return false;
}

fs::path SceneRoots::resolve(const std::string& requested) const {
  if (requested.empty()) throw InvalidArgument("scene_path is empty");
  if (roots_.empty()) {
    throw PermissionDenied(fmt::format(
        "scene path '{}' refused: the daemon has no scene roots (start it with --scene-root)",
        requested));
  }

  const fs::path request(requested);
  std::vector<fs::path> candidates;
  if (request.is_absolute()) {
    candidates.push_back(request);
  } else {
    for (const fs::path& root : roots_) candidates.push_back(root / request);
  }

  fs::path denied;    // first candidate that resolved outside the roots
  fs::path missing;   // first candidate inside a root that does not exist
  for (const fs::path& candidate : candidates) {
    std::error_code ec;
    // weakly_canonical follows the symlinks of the existing prefix and
    // normalizes the rest, so a missing file below a symlinked directory
    // is still judged by where it really is.
    fs::path resolved = fs::weakly_canonical(candidate, ec);
    if (ec) {
      throw InvalidArgument(
          fmt::format("scene path '{}' cannot be resolved: {}", requested, ec.message()));
    }
    if (!contains(resolved)) {
      if (denied.empty()) denied = resolved;
      continue;
    }
    fs::file_status status = fs::status(resolved, ec);
    if (ec || !fs::exists(status)) {
      if (missing.empty()) missing = resolved;
      continue;
    }
    if (!fs::is_regular_file(status)) {
      throw InvalidArgument(
          fmt::format("scene path '{}' ({}) is not a regular file", requested, resolved.string()));
    }
    return resolved;
  }
  if (!missing.empty()) {
    throw NotFound(fmt::format("scene '{}' not found (looked for '{}')", requested,
                               missing.string()));
  }
  throw PermissionDenied(fmt::format("scene path '{}' resolves to '{}', outside the scene roots [{}]",
                                     requested, denied.string(), join_paths(roots_)));
}

}  // namespace pbgi::service
