// A page set: the on-disk tree of one scene + build options, in its own
// directory (content-addressed: the directory name is the build key).
//   <dir>/manifest.pbgm   magic, format version, options, stats, root, codec,
//                         page table, checksum
//   <dir>/pages.pbgp      pages of at most options.page_size bytes, each a
//                         connected subtree (treelet) with header + checksum
// Built from a stream of surfels with bounded memory (PageSetBuilder) and
// published atomically: written into a temporary directory, fsynced, renamed.
// Byte layout: storage/format/FORMAT.md.
#pragma once

#include "storage/codecs/glossy_pages.h"
#include "storage/format/format_version.h"
#include "storage/pages/page_table.h"
#include "storage/tree/build_options.h"
#include "storage/tree/node.h"
#include "storage/tree/region_grid.h"
#include "storage/tree/surfel.h"

#include <Imath/ImathBox.h>

#include <filesystem>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace pbgi::storage {

class PageCache;
class StagingQuota;

struct PageSetStats {
  uint64_t surfel_count = 0;
  uint64_t node_count = 0;
  uint64_t leaf_count = 0;
  uint32_t page_count = 0;
  uint32_t max_depth = 0;   // depth of the deepest leaf; the root has depth 0
  uint64_t file_bytes = 0;  // size of pages.pbgp
};

inline constexpr char kManifestFileName[] = "manifest.pbgm";
inline constexpr char kPagesFileName[] = "pages.pbgp";

struct Manifest {
  std::string build_key;  // content hash of scene + options
  tree::BuildOptions options;
  PageSetStats stats;
  tree::NodeRef root;
  uint32_t codec = 0;  // payload codec id (0 = float SH)
  // Every node stores its payload (V3 pages) rather than deriving it (V2).
  bool node_payloads = false;
  // The codec's serialized state (the kmeans-sh LUT); empty for float SH.
  std::vector<uint8_t> codec_state;
  uint32_t page_format = kPageFormatCurrent;  // format version of every page
  PageTable pages;                            // page table, indexed by page id (page_table.h)
  // Glossy radiance (storage/codecs/glossy_pages.h): cube map resolution,
  // 0 when no page stores any (V2 manifest). Pages that do carry
  // kPageFlagGlossy.
  uint32_t glossy_resolution = 0;
  // Air regions (storage/tree/region_grid.h; V6 manifest): the grid and
  // each region's subtree, or both empty when the tree does not keep
  // regions apart.
  tree::RegionGrid regions;
  std::vector<tree::RegionRoot> region_roots;
};

// What a build measured (not stored; for logs and benchmarks).
struct BuildReport {
  uint64_t surfels = 0;
  uint32_t runs = 0;                     // sorted runs spilled to disk (0: sorted in memory)
  uint32_t merges = 0;                   // k-way merges of those runs
  uint64_t run_bytes = 0;                // bytes written to run files (compressed), all merge passes
  uint64_t sort_peak_bytes = 0;          // largest run + merge buffers (<= options.sort_memory_bytes)
  uint64_t tree_peak_pending_bytes = 0;  // largest size of nodes waiting for their page
  double add_seconds = 0;                // inside add(): copying, sorting and spilling runs
  std::string payload_codec;             // what was stored: "derived", "float32-sh", "kmeans-sh"
  std::string codec_reason;              // why (storage/codecs/codec_selection.h), for logs
  uint64_t lut_sample_surfels = 0;       // kmeans-sh: surfels of the LUT's sample tree
  uint32_t lut_entries = 0;              // kmeans-sh: entries learned (<= lut_entries asked)
  double lut_seconds = 0;                // kmeans-sh: sample tree + k-means (inside finish)
  double finish_seconds = 0;             // merge, tree, pages, manifest, publish
  // Glossy radiance (with a GlossyShader and glossy surfels; all zero
  // when no page stores any).
  GlossyPageStats glossy;
};

// A streaming build of one page set: surfels arrive in batches in any
// order, are sorted externally by Morton code within a hard memory bound
// (options.sort_memory_bytes), and the tree is built bottom-up from the
// sorted stream, each page written as soon as it is complete
// (storage/tree/streaming_tree_builder.h). Nothing proportional to the
// surfel count is held in memory but the page table (~2.25 bytes a page,
// page_table.h: 0.16 GB for a billion surfels), whose growth the build
// reports (set_memory_hook) before it allocates.
//
// Everything is written into a staging directory next to `dir` and
// published by one atomic rename in finish(); a build that fails, is
// cancelled or destroyed before finish() leaves nothing behind, and one
// killed outright leaves a staging directory that the next build in the
// same parent removes (StagingDir).
//
// The page set depends only on the surfels (in arrival order), `bounds`
// and the tree options (leaf_size, page_size, payload_codec, lut_entries,
// lut_sample_fraction): never on the batch sizes or the sort memory.
//
// Payloads (options.payload_codec, FORMAT.md "Payload storage"): derived
// writes V2 pages; float32-sh and kmeans-sh store every node's payload in
// V3 pages. kmeans-sh first learns its LUT on a tree over a random sample
// of the surfels (lut_sample_fraction, drawn while they arrive) and stores
// it in the manifest; auto resolves by codec_selection.h (derived for
// diffuse scenes).
//
// Thread-safety: one thread drives a builder.
class PageSetBuilder {
 public:
  // `bounds` orders the surfels (the cube around it is Morton-coded);
  // surfels outside it are still stored. Throws InvalidArgument (options,
  // build key longer than 4096 bytes, `dir` exists, parent missing),
  // IoError.
  PageSetBuilder(const tree::BuildOptions& options, std::string build_key, const std::filesystem::path& dir,
                 const Imath::Box3f& bounds);
  ~PageSetBuilder();
  PageSetBuilder(const PageSetBuilder&) = delete;
  PageSetBuilder& operator=(const PageSetBuilder&) = delete;

  // Appends surfels in arrival order (copied). Throws InvalidArgument for
  // an invalid surfel, naming its arrival index (storage/tree/surfel_checks.h).
  void add(std::span<const Surfel> surfels);
  // Air regions (storage/tree/region_grid.h): the grid the surfels'
  // regions were looked up in, stored with the page set when the tree
  // keeps more than one region apart. Call before finish().
  void set_regions(tree::RegionGrid grid);
  // Codes glossy senders' outgoing radiance into the pages, lit by
  // `shader` (storage/codecs/glossy_pages.h; null, the default: glossy
  // surfels keep only their diffuse radiance). Call before finish(); the
  // shader must outlive it.
  void set_glossy_shader(const GlossyShader* shader);
  // Charges what the build writes into its staging directory (sort runs,
  // pages, manifest) to `quota` (staging_quota.h; null, the default: no
  // limit): add() and finish() throw ResourceExhausted, and the build
  // leaves nothing behind, if a write would pass it. Call before add().
  void set_staging_quota(std::shared_ptr<StagingQuota> quota);
  // Reports the bytes the build holds that grow with its pages (the page
  // table) before each growth, with everything held while it happens (the
  // old and the new arrays while the table moves), and once more when
  // finish() has shrunk the table to its size: a daemon charges them to
  // its memory budget (server/engine/scene_session.cpp). Called on the
  // thread that calls finish(); an exception the hook throws (a budget
  // that cannot give the bytes: ResourceExhausted) stops the build, which
  // leaves nothing behind. Call before finish().
  void set_memory_hook(std::function<void(uint64_t bytes)> hook);

  // Merges, builds the tree, writes pages and manifest, fsyncs and
  // publishes. `progress` gets increasing fractions in [0, 1] on this
  // thread; an exception it throws cancels the build. InvalidArgument if no
  // surfel was added. The builder is spent afterwards.
  Manifest finish(const std::function<void(float)>& progress = {});

  const BuildReport& report() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Builds the page set of `surfels` (consumed) in `dir`: a PageSetBuilder
// over the bounds of their positions. Returns the manifest. `progress` gets
// fractions in [0, 1] on the calling thread; an exception it throws cancels
// the build. On any failure nothing is left behind. Throws InvalidArgument
// (options, surfels, `dir` exists, parent missing), IoError (naming the
// file). `report`, if given, receives the build's measurements.
Manifest build_page_set(std::vector<Surfel> surfels, const tree::BuildOptions& options, const std::string& build_key,
                        const std::filesystem::path& dir, const std::function<void(float)>& progress = {},
                        BuildReport* report = nullptr, const GlossyShader* glossy = nullptr);

// Called on each page a PageSetReader loads, after decoding and before
// anything is cached or shared, to attach what the caller derives from it
// (tree::PageAttachment, which it must set). A reader with a decorator
// keeps only that attachment: what it caches and charges is the
// attachment alone (a gather's view, a few times smaller than the decoded
// page and its Page record), attachment() returns it, and page() returns a
// page holding only its id and the attachment. The reader decodes into a
// scratch page per thread and reuses its arrays for the next page.
// Must be thread-safe (concurrent loads); what it throws fails the load
// and nothing is cached.
using PageDecorator = std::function<void(tree::Page&)>;

// Reads a published page set; pages are loaded on demand through `cache`
// (nullptr: no caching, every page() call reads and decodes), each passed
// through `decorate` if given (then the reader keeps attachments only).
// Thread-safety: all methods may be called concurrently (pread on one fd).
// page() verifies the page's checksum and structure on every load.
class PageSetReader : public tree::TreeSource {
 public:
  // Reads and verifies the manifest; checks the pages file size.
  // Throws CorruptionError / VersionError / IoError naming the file,
  // NotFound if there is no manifest in `dir`.
  PageSetReader(const std::filesystem::path& dir, std::shared_ptr<PageCache> cache, PageDecorator decorate = {});
  ~PageSetReader() override;

  tree::NodeRef root() const override;
  // Throws CorruptionError / VersionError / IoError naming the file and
  // page; InvalidArgument for an id >= page count.
  tree::PagePtr page(uint32_t id) const override;
  // With a decorator: page `id`'s attachment, loaded through the cache.
  // Without: null. Throws as page().
  std::shared_ptr<const tree::PageAttachment> attachment(uint32_t id) const override;
  const tree::RegionGrid* regions() const override;
  std::span<const tree::RegionRoot> region_roots() const override;
  const Manifest& manifest() const;
  const std::filesystem::path& directory() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace pbgi::storage
