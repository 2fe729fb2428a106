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

SceneRoots::SceneRoots(const std::vector<fs::path>& roots) : roots_(roots) {}

fs::path SceneRoots::resolve(const std::string& requested) const {
  if (requested.empty()) throw InvalidArgument("scene_path is empty");
  if (requested.find('\0') != std::string::npos) {
    // The kernel would open only the part before the NUL: another file.
    throw InvalidArgument(fmt::format("scene_path '{}' contains a NUL byte",
                                      requested.substr(0, requested.find('\0'))));
  }
  if (roots().empty()) {
    throw PermissionDenied(fmt::format(
        "scene path '{}' refused: the daemon has no scene roots (start it with --scene-root)",
        requested));
  }

  const fs::path request(requested);
  std::vector<fs::path> candidates;
  if (request.is_absolute()) {
    candidates.push_back(request);
  } else {
    for (const fs::path& root : roots()) candidates.push_back(root / request);
  }

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
    if (!roots_.contains(resolved)) continue;
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
  // Where it resolved to is not said: a symlink's target outside the roots
  // would disclose the filesystem there.
  throw PermissionDenied(fmt::format("scene path '{}' is outside the scene roots [{}]", requested,
                                     join_paths(roots())));
}

}  // namespace pbgi::service
