#include "server/gather/factorized_gather.h"

#include "server/gather/volume_fragments.h"
#include "storage/tree/morton.h"

#include <algorithm>

namespace pbgi::gather {

namespace {
// What a batch keeps pinned between receivers at most: past it, the
// pages the most recent receivers used stay pinned, down to 3/4 of it
// (PagePins::trim). ~7,500 views of a 2M-surfel city (~1,100 bytes each),
// the pages a tile's clusters share. Pinned pages are memory beside the
// page cache's budget. Keeping only the last cluster's pages (past 4,096
// pages) fetched a quarter more pages, with the same peak of pinned pages
// beyond the cache (docs/measurements/2026-11-28-pinned-pages.md).
constexpr uint64_t kBatchPinnedBytes = uint64_t(8) << 20;
}  // namespace

uint32_t cluster_count(uint32_t k_per_1024, size_t n) {
  const uint64_t k = (uint64_t(k_per_1024) * n + 1023) / 1024;
  return uint32_t(std::clamp<uint64_t>(k, 1, std::max<size_t>(n, 1)));
}

FactorizedGather::FactorizedGather(CutWalker& walker)
    : walker_(walker),
      far_(CubeLayout::get(walker.options().microbuffer_resolution),
           depth_band_for(walker.options())) {
  near_.reserve(1024);
}

void FactorizedGather::visit_in_space_order(const std::vector<ReceiverCluster>& clusters) {
  Imath::Box3f box;
  for (const ReceiverCluster& c : clusters) box.extendBy(c.frame.p);
  const tree::MortonFrame frame(box);
  keyed_.resize(clusters.size());
  for (size_t i = 0; i < clusters.size(); ++i) keyed_[i] = {frame.code(clusters[i].frame.p), uint32_t(i)};
  std::sort(keyed_.begin(), keyed_.end());
  order_.resize(clusters.size());
  for (size_t i = 0; i < clusters.size(); ++i) order_[i] = keyed_[i].second;
}

void FactorizedGather::gather(std::span<const Receiver> rs, std::span<GatherResult> results,
                              GatherCounters& counters, GlossyGather* glossy, const VolumePoints* fog) {
  const GatherOptions& o = walker_.options();
  clusters_.build(rs, cluster_count(o.clusters, rs.size()));

  PagePins& pins = walker_.pins();
  // Pages stay pinned across the batch's clusters: neighbouring clusters
  // walk mostly the same pages, so each is fetched once per batch instead
  // of once per cluster (under a page cache smaller than a tile's pages,
  // each of those fetches was a miss: a 2M-surfel city at 1/8 of its page
  // set hit 13% of them). Past kBatchPinnedBytes, the pages the most
  // recent receivers used stay pinned, down to 3/4 of it, after each
  // receiver and cluster; all are unpinned when the batch ends (also on
  // errors).
  const HoldPinsInScope hold{pins};
  // After each receiver and each cluster: a new run, and past the bound
  // the least recently used pages no entry refers to are unpinned.
  auto end_run = [&pins] {
    pins.next_run();
    if (pins.pinned_bytes() > kBatchPinnedBytes) pins.trim(kBatchPinnedBytes / 4 * 3);
  };

  const std::vector<uint32_t>& members = clusters_.members();
  const std::vector<ReceiverCluster>& all = clusters_.clusters();
  visit_in_space_order(all);
  for (const uint32_t ci : order_) {
    const ReceiverCluster& c = all[ci];
    // 1-2. The cluster's coarse cut and far content, from the root of its
    //      members' air region (the whole tree if they differ).
    uint32_t region = walker_.region_of(rs[members[c.first]]);
    for (uint32_t m = c.first + 1; m < c.first + c.count && region != tree::kAnyRegion; ++m) {
      if (walker_.region_of(rs[members[m]]) != region) region = tree::kAnyRegion;
    }
    far_.begin();
    near_.clear();
    walker_.walk_cluster(c.frame, region, far_, near_);
    far_.resolve(o.ao_max_distance);
    // 3. Each member refines the near nodes.
    for (uint32_t m = c.first; m < c.first + c.count; ++m) {
      const uint32_t i = members[m];
      walker_.begin_receiver(rs[i].position, rs[i].normal);
      // Pushed last to first: popped in the cut's pre-order.
      for (size_t j = near_.size(); j-- > 0;) walker_.push(near_[j]);
      walker_.walk_receiver();
      if (fog) add_volume_fragments(*fog, rs[i].position, walker_.buffer());
      const bool lobe = glossy && rs[i].glossy.active();
      const Resolved r = lobe ? glossy->resolve(rs[i], walker_, &far_) : walker_.resolve(&far_);
      results[i].irradiance = r.irradiance;
      results[i].ao = r.ao;
      if (o.bent_normal) results[i].bent_normal = walker_.buffer().bent_normal(r);
      if (lobe) {
        results[i].glossy = r.reflected + glossy->refined(rs[i], region, counters, fog);
        ++counters.glossy_receivers;
      }
      ++counters.receivers;
      // A cluster's receivers refine near nodes into thousands of pages
      // between them (up to 11 MiB pinned in one cluster of the 2M city):
      // trimmed after each, the near entries' pages kept.
      end_run();
    }
    for (const StackEntry& e : near_) pins.release(e.pin);
    counters.pages_fetched += pins.take_fetches();
    end_run();
    pins.compact();
  }
}

}  // namespace pbgi::gather
