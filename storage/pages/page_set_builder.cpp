// build_page_set(): surfels -> tree -> pages -> manifest -> atomic publish.
#include "storage/codecs/payload_codec.h"
#include "storage/format/errors.h"
#include "storage/format/page_records.h"
#include "storage/pages/file_io.h"
#include "storage/pages/manifest_file.h"
#include "storage/pages/page_encoding.h"
#include "storage/pages/page_layout.h"
#include "storage/pages/page_set.h"
#include "storage/pages/staging_dir.h"
#include "storage/tree/tree_builder.h"

namespace pbgi::storage {

namespace fs = std::filesystem;

namespace {

// Pages start at multiples of this in pages.pbgp (zero padding between):
// a page then spans the fewest filesystem blocks, and a later reader may
// use O_DIRECT. Readers take offsets from the page table, not from this.
constexpr uint64_t kPageAlignment = 4096;
// Pages are written through a buffer of about this size.
constexpr size_t kWriteBufferBytes = size_t(4) << 20;
constexpr size_t kMaxBuildKeyBytes = 4096;

// Assembles page `id` of the plan as a decoded page with page-relative links.
void assemble_page(const tree::BuiltTree& t, const PagePlan& plan, uint32_t id,
                   std::vector<uint32_t>& scratch, tree::Page& out) {
  page_nodes(t, plan, id, scratch);
  out.id = id;
  out.nodes.clear();
  out.surfels.clear();
  for (uint32_t x : scratch) {
    tree::Node n = t.nodes[x];
    for (uint32_t c = 0; c < n.child_count; ++c) {
      const uint32_t ci = n.children[c].index;
      n.children[c] = {plan.page_of[ci], plan.index_in_page[ci]};
    }
    if (n.is_leaf()) {
      const auto first = t.surfels.begin() + n.first_surfel;
      n.first_surfel = static_cast<uint32_t>(out.surfels.size());
      out.surfels.insert(out.surfels.end(), first, first + n.surfel_count);
    }
    out.nodes.push_back(n);
  }
}

// Writes every page of the plan to `path`; returns the page table.
std::vector<PageExtent> write_pages(const tree::BuiltTree& t, const PagePlan& plan,
                                    const PayloadCodec& codec, const fs::path& path,
                                    const std::function<void(float)>& report) {
  File file = File::create_new(path);
  std::vector<PageExtent> table(plan.page_count());
  std::vector<uint8_t> buffer, encoded;
  buffer.reserve(kWriteBufferBytes + 2 * kPageAlignment);
  std::vector<uint32_t> scratch;
  tree::Page page;
  uint64_t offset = 0;
  for (uint32_t id = 0; id < plan.page_count(); ++id) {
    assemble_page(t, plan, id, scratch, page);
    encode_page(page, codec, encoded);
    const uint64_t aligned = (offset + kPageAlignment - 1) / kPageAlignment * kPageAlignment;
    buffer.resize(buffer.size() + (aligned - offset), 0);
    buffer.insert(buffer.end(), encoded.begin(), encoded.end());
    table[id] = {aligned, static_cast<uint32_t>(encoded.size())};
    offset = aligned + encoded.size();
    if (buffer.size() >= kWriteBufferBytes) {
      file.write_all(buffer);
      buffer.clear();
    }
    report(float(id + 1) / float(plan.page_count()));
  }
  file.write_all(buffer);
  file.sync();
  file.close();
  return table;
}

}  // namespace

Manifest build_page_set(std::vector<Surfel> surfels, const tree::BuildOptions& options,
                        const std::string& build_key, const fs::path& dir,
                        const std::function<void(float)>& progress) {
  auto report = [&](float f) {
    if (progress) progress(f);
  };
  // 1. Check everything cheap before the long work.
  options.validate();
  if (build_key.size() > kMaxBuildKeyBytes) {
    throw InvalidArgument("build key of " + std::to_string(build_key.size()) +
                          " bytes is longer than " + std::to_string(kMaxBuildKeyBytes));
  }
  StagingDir::check_target(dir);
  report(0.f);

  // 2. The tree, in memory.
  const tree::BuiltTree t = tree::build_tree(std::move(surfels), options);
  report(0.5f);

  // 3. Which nodes go to which page.
  const auto codec = make_payload_codec(static_cast<uint32_t>(CodecId::kFloatSh));
  const PagePlan plan =
      plan_pages(t, options.page_size - kPageHeaderBytes - kPageTrailerBytes,
                 kTopologyRecordBytes + codec->bytes_per_node(), kSurfelRecordBytes);
  report(0.55f);

  // 4. Pages, then the manifest that describes them, into the staging dir.
  StagingDir staging(dir);
  Manifest m;
  m.build_key = build_key;
  m.options = options;
  m.codec = codec->id();
  m.page_format = kPageFormatCurrent;
  m.root = {0, 0};
  m.pages = write_pages(t, plan, *codec, staging.path() / kPagesFileName,
                        [&](float f) { report(0.55f + 0.4f * f); });
  m.stats.surfel_count = t.surfels.size();
  m.stats.node_count = t.nodes.size();
  m.stats.leaf_count = t.leaf_count;
  m.stats.page_count = plan.page_count();
  m.stats.max_depth = t.max_depth;
  m.stats.file_bytes = m.pages.empty() ? 0 : m.pages.back().offset + m.pages.back().bytes;
  {
    File f = File::create_new(staging.path() / kManifestFileName);
    f.write_all(encode_manifest(m));
    f.sync();
    f.close();
  }

  // 5. Publish: one rename makes the complete page set visible.
  staging.publish();
  report(1.f);
  return m;
}

}  // namespace pbgi::storage
