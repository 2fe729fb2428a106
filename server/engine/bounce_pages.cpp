#include "server/engine/bounce_pages.h"

#include "common/errors.h"

#include <Imath/ImathColor.h>

#include <spdlog/spdlog.h>

#include <vector>

namespace pbgi {
namespace {

// Surfels gathered per call of gather_bounce(): enough batches of
// kBounceBatch to keep every core busy, small enough that the copies stay
// a few MiB whatever the scene's size.
constexpr size_t kSurfelsPerPass = 64 * kBounceBatch;

}  // namespace

storage::Manifest build_bounce_page_set(const storage::PageSetReader& direct, const tree::TreeSource& previous,
                                        const BounceOptions& options, const tree::BuildOptions& tree_options,
                                        const std::string& build_key, const std::filesystem::path& dir,
                                        const Imath::Box3f& bounds, const BounceGlossy& glossy,
                                        const std::function<void(float)>& progress,
                                        const std::function<bool()>& cancelled,
                                        std::shared_ptr<storage::StagingQuota> staging_quota,
                                        const std::function<void(uint64_t)>& memory_hook) {
  options.validate();
  storage::PageSetBuilder builder(tree_options, build_key, dir, bounds);
  builder.set_staging_quota(std::move(staging_quota));
  if (glossy.shader) builder.set_glossy_shader(glossy.shader);
  std::vector<Surfel> batch;
  std::vector<Imath::C3f> radiance;
  batch.reserve(kSurfelsPerPass + 4096);
  radiance.reserve(batch.capacity());

  // The gather phase is most of the work: it gets [0, 0.9] of the progress.
  // The receivers' full surfels (albedo, emission) from a reader of the
  // same set without the gather's views: a page that carries its view
  // keeps only what gathers read (gather::attach_view). Not cached: each
  // page is read once.
  const storage::PageSetReader receivers(direct.directory(), nullptr);
  // Its page table is one more copy of the direct set's, held as long as
  // the build's own.
  if (memory_hook) {
    const uint64_t copy = receivers.manifest().pages.memory_bytes();
    memory_hook(copy);
    builder.set_memory_hook([&memory_hook, copy](uint64_t bytes) { memory_hook(copy + bytes); });
  }
  const uint32_t pages = direct.manifest().stats.page_count;
  // Air regions: the direct set's, kept. Each region's pages precede its
  // root's page (the streaming build closes a region's subtree before the
  // next region's first surfel), so a page's surfels are of the first
  // region whose root page is not before it.
  const std::span<const tree::RegionRoot> roots = direct.region_roots();
  if (!roots.empty()) builder.set_regions(*direct.regions());
  size_t next_root = 0;
  BounceGatherStats gathered;
  auto flush = [&](uint32_t pages_done) {
    if (batch.empty()) return;
    const BounceGatherStats st = gather_bounce(previous, batch, radiance, options, cancelled);
    gathered.receivers += st.receivers;
    gathered.gathered += st.gathered;
    gathered.fallback += st.fallback;
    if (glossy.restore) glossy.restore(batch);
    builder.add(batch);
    batch.clear();
    radiance.clear();
    if (progress) progress(0.9f * float(pages_done) / float(pages));
  };
  for (uint32_t id = 0; id < pages; ++id) {
    const tree::PagePtr page = receivers.page(id);
    while (next_root < roots.size() && roots[next_root].root.page < id) ++next_root;
    const uint32_t region = next_root < roots.size() ? roots[next_root].region : tree::kAnyRegion;
    for (const Surfel& s : page->surfels) {
      batch.push_back(s);
      batch.back().region = roots.empty() ? tree::kAnyRegion : region;
      radiance.push_back(s.radiance);
    }
    if (batch.size() >= kSurfelsPerPass) flush(id + 1);
  }
  flush(pages);
  spdlog::info(
      "bounce page set {}: {} receivers, {} gathered ({} where no representative fitted), receiver "
      "stride {}, microbuffer {}, cut {} sr",
      build_key, gathered.receivers, gathered.gathered, gathered.fallback, options.receiver_stride,
      options.gather.microbuffer_resolution, options.gather.max_solid_angle);
  return builder.finish([&](float f) {
    if (cancelled && cancelled()) throw Cancelled("bounce page set " + build_key + " cancelled while writing pages");
    if (progress) progress(0.9f + 0.1f * f);
  });
}

}  // namespace pbgi
