// PageSetBuilder: surfels -> external sort -> streaming tree -> pages ->
// manifest -> atomic publish.
#include "common/errors.h"
#include "storage/codecs/codec_selection.h"
#include "storage/codecs/glossy_pages.h"
#include "storage/codecs/payload_codec.h"
#include "storage/codecs/quantized_sh_codec.h"
#include "storage/codecs/sh_lut.h"
#include "storage/pages/file_io.h"
#include "storage/pages/lut_sample.h"
#include "storage/pages/manifest_file.h"
#include "storage/pages/page_encoding.h"
#include "storage/pages/page_set.h"
#include "storage/pages/staging_dir.h"
#include "storage/pages/surfel_sorter.h"
#include "storage/tree/morton.h"
#include "storage/tree/page_records.h"
#include "storage/tree/payload_rounding.h"
#include "storage/tree/streaming_tree_builder.h"
#include "storage/tree/surfel_checks.h"
#include "storage/tree/tree_builder.h"

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <limits>
#include <optional>

namespace pbgi::storage {

namespace fs = std::filesystem;

namespace {

// Pages are written through a buffer of about this size.
constexpr size_t kWriteBufferBytes = size_t(4) << 20;
// The page table's reservation grows by half, at least by this many pages
// (9 KiB): 25 growths, each reported before it, for 71.6 M pages.
constexpr size_t kTableGrowthPages = 4096;
constexpr size_t kMaxBuildKeyBytes = 4096;

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// Encodes each treelet as the next page of pages.pbgp, right after the
// previous one (V4 pages are small: aligning them would cost more padding
// than page bytes), through a write buffer; keeps the page table, whose
// growth it reports to the build's memory hook before it allocates.
class PageWriter final : public tree::TreeletSink {
 public:
  // `glossy`: glossy senders' radiance is coded into the pages (null: none).
  // `memory_hook`: PageSetBuilder::set_memory_hook's (may be empty).
  PageWriter(const fs::path& path, std::shared_ptr<const PayloadCodec> codec, GlossyPageEncoder* glossy,
             StagingUsage& usage, std::function<void(uint64_t)> memory_hook)
      : file_(File::create_new(path)),
        codec_(std::move(codec)),
        glossy_(glossy),
        usage_(usage),
        memory_hook_(std::move(memory_hook)) {
    buffer_.reserve(2 * kWriteBufferBytes);
  }

  uint32_t write(const tree::Treelet& t) override {
    const uint32_t id = static_cast<uint32_t>(table_.size());
    if (table_.size() >= std::numeric_limits<uint32_t>::max() - 1) {
      throw InvalidArgument("tree needs more than 2^32 pages; raise tree.page_size");
    }
    encode_page(t, id, *codec_, encoded_, glossy_section(t, id));
    buffer_.insert(buffer_.end(), encoded_.begin(), encoded_.end());
    if (table_.size() == reserved_) grow_table();
    table_.push_back({offset_, static_cast<uint32_t>(encoded_.size())});
    offset_ += encoded_.size();
    if (buffer_.size() >= kWriteBufferBytes) flush();
    return id;
  }

  // Writes what is buffered, fsyncs and closes; returns the page table.
  PageTable close() {
    flush();
    file_.sync();
    file_.close();
    // Shrinking copies the table: both copies are held for a moment.
    report(table_.memory_bytes() + PageTable::bytes_for(table_.size()));
    table_.shrink_to_fit();
    report(table_.memory_bytes());
    return std::move(table_);
  }
  uint64_t file_bytes() const { return offset_; }

 private:
  void report(uint64_t bytes) {
    if (memory_hook_) memory_hook_(bytes);
  }
  // Reserves room for more pages, reported first with the old arrays and
  // the new ones both (they are, while the entries move), then with the
  // new ones alone. A page of 64 KiB or more adds an entry apart
  // (page_table.h), counted at the next report.
  void grow_table() {
    const size_t pages = reserved_ + std::max(kTableGrowthPages, reserved_ / 2);
    report(table_.memory_bytes() + PageTable::bytes_for(pages));
    table_.reserve(pages);
    reserved_ = pages;
    report(table_.memory_bytes());
  }

  void flush() {
    usage_.charge(buffer_.size(), file_.path());
    file_.write_all(buffer_);
    buffer_.clear();
  }

  // The page's glossy radiance: its own glossy surfels and its linked
  // children's root averages, coded over the page as a reader decodes it.
  std::vector<uint8_t> glossy_section(const tree::Treelet& t, uint32_t id) {
    if (!glossy_) return {};
    const bool linked = std::any_of(t.links.begin(), t.links.end(),
                                    [&](const tree::TreeletLink& l) { return glossy_->has_root(l.page); });
    if (t.gloss.empty() && !linked) return {};
    tree::expand_treelet(t.view(), id, "page " + std::to_string(id) + " (being written)", page_);
    link_areas_.clear();
    for (const tree::TreeletLink& l : t.links) link_areas_.push_back(l.summary.area);
    return glossy_->encode(page_, t.gloss, link_areas_);
  }

  File file_;
  std::shared_ptr<const PayloadCodec> codec_;
  GlossyPageEncoder* glossy_;
  StagingUsage& usage_;
  std::function<void(uint64_t)> memory_hook_;
  tree::Page page_;
  std::vector<float> link_areas_;
  PageTable table_;
  size_t reserved_ = 0;  // pages the table has room for
  std::vector<uint8_t> buffer_, encoded_;
  uint64_t offset_ = 0;
};

// The streaming build's view of a codec when every node stores a payload.
class CodecSizer final : public tree::NodePayloadSizer {
 public:
  explicit CodecSizer(const PayloadCodec& codec) : codec_(codec) {}
  uint32_t bits(const tree::Node& node) const override { return codec_.payload_bits(node); }

 private:
  const PayloadCodec& codec_;
};

// The LUT options a build derives from its tree options.
ShLutOptions lut_options(const tree::BuildOptions& o) {
  ShLutOptions lo;
  lo.entries = o.lut_entries;
  lo.sample_fraction = o.lut_sample_fraction;
  return lo;
}

bool may_quantize(const tree::BuildOptions& o) { return o.payload_codec == tree::PayloadCodecOption::kQuantizedSh; }

}  // namespace

struct PageSetBuilder::Impl {
  tree::BuildOptions options;
  std::string build_key;
  tree::MortonFrame frame;
  StagingDir staging;
  std::optional<SurfelSorter> sorter;
  BuildReport report;
  bool finished = false;
  std::vector<Surfel> batch;                     // checked copies on their way to the sorter
  std::optional<LutSampleCollector> lut_sample;  // kmeans-sh / auto: the LUT's sample
  const GlossyShader* glossy_shader = nullptr;   // glossy senders' lobes (null: none coded)
  uint64_t glossy_surfels = 0;                   // added surfels with a specular lobe
  tree::RegionGrid regions;                      // set_regions(): stored if the tree keeps regions apart
  std::function<void(uint64_t)> memory_hook;     // set_memory_hook()

  Impl(const tree::BuildOptions& o, std::string key, const fs::path& dir, const Imath::Box3f& bounds)
      : options(o), build_key(std::move(key)), frame(bounds), staging(checked(o, build_key, dir)) {
    sorter.emplace(frame, options.sort_memory_bytes, staging.path(), kDefaultSortFanIn, &staging.usage());
    if (may_quantize(options)) {
      const ShLutOptions lo = lut_options(options);
      lut_sample.emplace(lo.sample_fraction,
                         std::max(lo.min_sample_surfels, uint64_t(lo.min_surfels_per_entry) * lo.entries));
    }
  }

  // The codec of this build: resolves `auto` (codec_selection.h), and for
  // kmeans-sh learns the LUT on a tree over the sample.
  std::shared_ptr<const PayloadCodec> choose_codec(bool& node_payloads, bool& glossy_wavelets) {
    CodecSelectionOptions so;
    so.cube_resolution = options.glossy_resolution;
    // Lobes count only when the server can light them.
    const CodecSelection sel =
        select_payload_codecs({report.surfels, glossy_shader ? glossy_surfels : 0}, options.payload_codec, so);
    node_payloads = sel.node_payloads;
    glossy_wavelets = sel.glossy_wavelets;
    report.codec_reason = sel.reason;
    report.payload_codec = node_payloads ? "" : "derived";
    if (sel.diffuse != CodecId::kQuantizedSh) {
      if (node_payloads) report.payload_codec = "float32-sh";
      return make_payload_codec(static_cast<uint32_t>(CodecId::kFloatSh));
    }
    const auto t0 = Clock::now();
    std::vector<Surfel> sample = lut_sample->take();
    lut_sample.reset();
    report.lut_sample_surfels = sample.size();
    const tree::BuiltTree sample_tree = tree::build_tree(std::move(sample), options);
    ShLutTraining training = train_sh_lut(sample_tree.nodes, lut_options(options));
    report.lut_entries = static_cast<uint32_t>(training.table.size());
    report.lut_seconds = seconds_since(t0);
    report.payload_codec = "kmeans-sh";
    return std::make_shared<const QuantizedShCodec>(
        std::make_shared<const QuantizedShTable>(std::move(training.table)));
  }

  // Checks everything cheap before the staging directory is created.
  static const fs::path& checked(const tree::BuildOptions& o, const std::string& key, const fs::path& dir) {
    o.validate();
    if (key.size() > kMaxBuildKeyBytes) {
      throw InvalidArgument("build key of " + std::to_string(key.size()) + " bytes is longer than " +
                            std::to_string(kMaxBuildKeyBytes));
    }
    return dir;
  }

  void add(std::span<const Surfel> surfels) {
    if (finished) throw InvalidArgument("page set builder: add() after finish()");
    const auto t0 = Clock::now();
    // Check a batch at a time: the sorter copies what it is given.
    constexpr size_t kBatch = 4096;
    batch.resize(kBatch);
    for (size_t at = 0; at < surfels.size(); at += kBatch) {
      const size_t n = std::min(kBatch, surfels.size() - at);
      for (size_t i = 0; i < n; ++i) {
        batch[i] = surfels[at + i];
        tree::check_surfel(batch[i], report.surfels + i);
        if (batch[i].gloss.glossy()) ++glossy_surfels;
      }
      sorter->add({batch.data(), n});
      if (lut_sample) lut_sample->add({batch.data(), n});
      report.surfels += n;
    }
    report.add_seconds += seconds_since(t0);
  }

  Manifest finish(const std::function<void(float)>& progress) {
    if (finished) throw InvalidArgument("page set builder: finish() called twice");
    finished = true;
    const auto t0 = Clock::now();
    auto report_progress = [&](float f) {
      if (progress) progress(f);
    };
    report_progress(0.f);
    if (report.surfels == 0) throw InvalidArgument("cannot build a tree over 0 surfels");

    // 1. The payload codec (kmeans-sh: its LUT, from the sample tree).
    bool node_payloads = false, glossy_wavelets = false;
    const auto codec = choose_codec(node_payloads, glossy_wavelets);
    const CodecSizer sizer(*codec);

    // 2. The sorted stream into the tree builder; pages are written as the
    //    tree completes them (stored payloads: quantized by the page writer).
    // Glossy radiance only when some surfel has a lobe and the server said
    // how to light it: diffuse scenes never pay for it.
    std::optional<GlossyPageEncoder> glossy;
    if (glossy_wavelets) {
      glossy.emplace(*glossy_shader, GlossyPageOptions{options.glossy_resolution, options.wavelet_threshold});
    }
    PageWriter pages(staging.path() / kPagesFileName, codec, glossy ? &*glossy : nullptr, staging.usage(), memory_hook);
    tree::StreamingTreeBuilder tree(options, options.page_size, node_payloads ? 0 : tree::kRoundedPayloadBytes, pages,
                                    node_payloads ? &sizer : nullptr);
    sorter->drain([&](const Surfel& s, uint64_t code) { tree.add(s, code); },
                  [&](float f) { report_progress(0.95f * f); });
    const tree::StreamingTreeStats stats = tree.finish();
    const SortStats& sort = sorter->stats();
    report.runs = sort.runs;
    report.merges = sort.merges;
    report.run_bytes = sort.run_bytes;
    report.sort_peak_bytes = sort.peak_bytes;
    report.tree_peak_pending_bytes = stats.peak_pending_bytes;
    sorter.reset();

    // 3. The manifest that describes the pages.
    Manifest m;
    m.build_key = build_key;
    m.options = options;
    m.codec = codec->id();
    m.node_payloads = node_payloads;
    m.codec_state = codec->state();
    m.page_format = node_payloads ? kPageFormatNodePayloads : kPageFormatCurrent;
    m.root = stats.root;
    if (!stats.region_roots.empty()) {
      if (regions.empty()) throw InvalidArgument("page set builder: surfels of several air regions but no region grid");
      m.regions = std::move(regions);
      m.region_roots = stats.region_roots;
    }
    if (glossy && glossy->stats().pages > 0) {
      m.glossy_resolution = options.glossy_resolution;
      report.glossy = glossy->stats();
    }
    m.stats.file_bytes = pages.file_bytes();
    m.pages = pages.close();
    m.stats.surfel_count = stats.surfel_count;
    m.stats.node_count = stats.node_count;
    m.stats.leaf_count = stats.leaf_count;
    m.stats.page_count = stats.page_count;
    m.stats.max_depth = stats.max_depth;
    {
      const std::vector<uint8_t> manifest = encode_manifest(m);
      File f = File::create_new(staging.path() / kManifestFileName);
      staging.usage().charge(manifest.size(), f.path());
      f.write_all(manifest);
      f.sync();
      f.close();
    }
    report_progress(0.97f);

    // 4. Publish: one rename makes the complete page set visible.
    staging.publish();
    report.finish_seconds = seconds_since(t0);
    report_progress(1.f);
    return m;
  }
};

PageSetBuilder::PageSetBuilder(const tree::BuildOptions& options, std::string build_key, const fs::path& dir,
                               const Imath::Box3f& bounds)
    : impl_(std::make_unique<Impl>(options, std::move(build_key), dir, bounds)) {}

PageSetBuilder::~PageSetBuilder() = default;

void PageSetBuilder::add(std::span<const Surfel> surfels) { impl_->add(surfels); }

void PageSetBuilder::set_glossy_shader(const GlossyShader* shader) { impl_->glossy_shader = shader; }

void PageSetBuilder::set_regions(tree::RegionGrid grid) { impl_->regions = std::move(grid); }

void PageSetBuilder::set_staging_quota(std::shared_ptr<StagingQuota> quota) {
  if (impl_->staging.usage().held() > 0) {
    throw InvalidArgument("page set builder: set_staging_quota() after bytes were written");
  }
  impl_->staging.usage().set_quota(std::move(quota));
}

void PageSetBuilder::set_memory_hook(std::function<void(uint64_t bytes)> hook) { impl_->memory_hook = std::move(hook); }

Manifest PageSetBuilder::finish(const std::function<void(float)>& progress) { return impl_->finish(progress); }

const BuildReport& PageSetBuilder::report() const { return impl_->report; }

Manifest build_page_set(std::vector<Surfel> surfels, const tree::BuildOptions& options, const std::string& build_key,
                        const fs::path& dir, const std::function<void(float)>& progress, BuildReport* report,
                        const GlossyShader* glossy) {
  PageSetBuilder builder(options, build_key, dir, tree::surfel_bounds(surfels));
  builder.set_glossy_shader(glossy);
  builder.add(surfels);
  std::vector<Surfel>().swap(surfels);
  const Manifest m = builder.finish(progress);
  if (report) *report = builder.report();
  return m;
}

}  // namespace pbgi::storage
