// Where the files a scene names may come from. The daemon serves scenes
// below its --scene-root directories, and every file such a scene resolves
// -- layers, textures, dome maps, OpenVDB and Draco files -- must lie below
// one of them too, or a scene inside a root could read any file the daemon
// can (`subLayers = [@/elsewhere/secret.usda@]`). Paths are judged after
// symlinks are resolved, so a symlink inside a root that points outside is
// outside.
//
// A default-constructed AssetRoots confines nothing: local tools (pbgi
// reference, bench, tests) read whatever they are given. The daemon passes
// its roots with each read (IngestOptions::asset_roots).
//
// Immutable after construction; thread-safe.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace pbgi {

class AssetRoots {
 public:
  AssetRoots() = default;  // unconfined
  // Confined to these directories (an empty list allows nothing).
  // Canonicalizes each; throws IoError naming a root that does not exist
  // or is not a directory.
  explicit AssetRoots(const std::vector<std::filesystem::path>& roots);

  bool confined() const { return confined_; }
  const std::vector<std::filesystem::path>& roots() const { return roots_; }  // canonical

  // True if `canonical` (already resolved) lies strictly below a root.
  bool contains(const std::filesystem::path& canonical) const;
  // True if `path` lies below a root once its symlinks are resolved (a
  // missing file is judged by where it would be); always true unconfined.
  bool allows(const std::filesystem::path& path) const;
  // Throws PermissionDenied "<what> is outside the scene roots" unless
  // allows(path). `what` names the file's user (a prim and field), never
  // the path: its location or a symlink's target would disclose the
  // filesystem outside the roots.
  void check(const std::filesystem::path& path, const std::string& what) const;

 private:
  bool confined_ = false;
  std::vector<std::filesystem::path> roots_;  // canonical
};

}  // namespace pbgi
