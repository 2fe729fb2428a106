// A page set: the on-disk tree of one scene + build options, in its own
// directory (content-addressed: the directory name is the build key).
//   <dir>/manifest.pbgm   magic, format version, options, stats, root, codec,
//                         page table, checksum
//   <dir>/pages.pbgp      pages of at most options.page_size bytes, each a
//                         connected subtree (treelet) with header + checksum
// Published atomically: written into a temporary directory, fsynced, renamed.
// Byte layout: storage/format/FORMAT.md.
#pragma once

#include "storage/format/format_version.h"
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
  uint32_t max_depth = 0;       // depth of the deepest leaf; the root has depth 0
  uint64_t file_bytes = 0;      // size of pages.pbgp
};

inline constexpr char kManifestFileName[] = "manifest.pbgm";
inline constexpr char kPagesFileName[] = "pages.pbgp";

// Where one page lives in pages.pbgp.
struct PageExtent {
  uint64_t offset = 0;
  uint32_t bytes = 0;
  bool operator==(const PageExtent&) const = default;
};

struct Manifest {
  std::string build_key;       // content hash of scene + options
  tree::BuildOptions options;
  PageSetStats stats;
  tree::NodeRef root;
  uint32_t codec = 0;          // payload codec id (0 = float SH)
  uint32_t page_format = kPageFormatCurrent;  // format version of every page
  std::vector<PageExtent> pages;              // page table, indexed by page id
};

// Builds the tree over `surfels` (consumed) and publishes it as a page set in
// `dir` (which must not exist yet; its parent must). Returns the manifest.
// `progress` gets fractions in [0, 1] on the calling thread; an exception it
// throws cancels the build. On any failure nothing is left behind.
// Throws InvalidArgument (options, surfels, `dir` exists, parent missing),
// IoError (naming the file).
Manifest build_page_set(std::vector<Surfel> surfels, const tree::BuildOptions& options,
                        const std::string& build_key, const std::filesystem::path& dir,
                        const std::function<void(float)>& progress = {});

// Reads a published page set; pages are loaded on demand through `cache`
// (nullptr: no caching, every page() call reads and decodes).
// Thread-safety: all methods may be called concurrently (pread on one fd).
// page() verifies the page's checksum and structure on every load.
class PageSetReader : public tree::TreeSource {
 public:
  // Reads and verifies the manifest; checks the pages file size.
  // Throws CorruptionError / VersionError / IoError naming the file,
  // NotFound if there is no manifest in `dir`.
  PageSetReader(const std::filesystem::path& dir, std::shared_ptr<PageCache> cache);
  ~PageSetReader() override;

  tree::NodeRef root() const override;
  // Throws CorruptionError / VersionError / IoError naming the file and
  // page; InvalidArgument for an id >= page count.
  tree::PagePtr page(uint32_t id) const override;
  const Manifest& manifest() const;
  const std::filesystem::path& directory() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace pbgi::storage
