// A page set: the on-disk tree of one scene + build options, in its own
// directory (content-addressed: the directory name is the build key).
//   <dir>/manifest.pbgm   magic, format version, stats, root, checksum
//   <dir>/pages.pbgp      fixed-size pages, each with header + checksum
// Published atomically: written into a temporary directory, fsynced, renamed.
#pragma once

#include "storage/tree/build_options.h"
#include "storage/tree/node.h"
#include "storage/tree/surfel.h"

#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace pbgi::storage {

class PageCache;

struct PageSetStats {
  uint64_t surfel_count = 0;
  uint64_t node_count = 0;
  uint64_t leaf_count = 0;
  uint32_t page_count = 0;
  uint32_t max_depth = 0;
  uint64_t file_bytes = 0;
};

struct Manifest {
  std::string build_key;       // content hash of scene + options
  tree::BuildOptions options;
  PageSetStats stats;
  tree::NodeRef root;
  uint32_t codec = 0;          // payload codec id (0 = float SH)
};

// Builds the tree over `surfels` (consumed) and publishes it as a page set in
// `dir` (which must not exist yet; its parent must). Returns the manifest.
Manifest build_page_set(std::vector<Surfel> surfels, const tree::BuildOptions& options,
                        const std::string& build_key, const std::filesystem::path& dir,
                        const std::function<void(float)>& progress = {});

// Reads a published page set; pages are loaded on demand through `cache`.
class PageSetReader : public tree::TreeSource {
 public:
  // Throws CorruptionError / VersionError / IoError naming the file.
  PageSetReader(const std::filesystem::path& dir, std::shared_ptr<PageCache> cache);
  ~PageSetReader() override;

  tree::NodeRef root() const override;
  tree::PagePtr page(uint32_t id) const override;
  const Manifest& manifest() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace pbgi::storage
