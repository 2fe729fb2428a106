// The daemon serves only scenes below its --scene-root directories. A
// requested path is resolved the way the kernel would open it (symlinks
// followed, "..", "." removed) before it is checked, so neither "../" nor a
// symlink inside a root can reach a file outside. The files the scene pulls
// in are confined to the same roots by the read (assets(), passed as
// IngestOptions::asset_roots; server/scene/asset_roots.h).
#pragma once

#include "common/errors.h"
#include "server/scene/asset_roots.h"

#include <filesystem>
#include <string>
#include <vector>

namespace pbgi::service {

// Immutable after construction; thread-safe.
class SceneRoots {
 public:
  // Canonicalizes each root; throws IoError naming a root that does not
  // exist or is not a directory.
  explicit SceneRoots(const std::vector<std::filesystem::path>& roots);

  // Returns the canonical path of the scene file. A relative request is
  // looked up below each root in order; an absolute one is taken as is.
  // Throws (checked in this order, so that nothing is revealed about
  // files outside the roots):
  //   InvalidArgument  empty request, or one holding a NUL byte (the
  //                    kernel would read only the part before it);
  //   PermissionDenied the path resolves outside every root (names the
  //                    request, never where it resolved to);
  //   NotFound         inside a root but no such file (names the path);
  //   InvalidArgument  it exists but is not a regular file.
  std::filesystem::path resolve(const std::string& requested) const;

  const std::vector<std::filesystem::path>& roots() const { return roots_.roots(); }
  // The roots as the confinement of everything a scene's read resolves.
  const AssetRoots& assets() const { return roots_; }

 private:
  AssetRoots roots_;  // confined
};

}  // namespace pbgi::service
