// The gather's public entry points (see docs/gather.md):
//  - gather(): one receiver, PBGI: start the microbuffer for the receiver's
//    hemisphere, walk the tree from the root (cut_walker.h), resolve
//    visibility per pixel and convolve with the cosine lobe;
//  - gather_tile(): a batch, with the method of the options (PBGI receiver
//    by receiver, or factorized PBGI, factorized_gather.h).
#include "server/gather/gather.h"

#include "common/errors.h"
#include "server/gather/cut_walker.h"
#include "server/gather/factorized_gather.h"
#include "server/gather/glossy_gather.h"
#include "server/gather/receiver_check.h"
#include "server/gather/volume_fragments.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

namespace pbgi {

struct Gatherer::Impl {
  Impl(const tree::TreeSource& tree, const GatherOptions& options, GatherCounters& counters,
       std::shared_ptr<GatherCache> c)
      : cache(std::move(c)),
        tree(tree),
        walker(tree, options, counters, cache ? &cache->impl() : nullptr) {}

  // The glossy receivers' lobes and fine walker, made on first use
  // (diffuse-only gathers never build them).
  gather::GlossyGather& glossy() {
    if (!glossy_) {
      glossy_ = std::make_unique<gather::GlossyGather>(tree, walker.options(),
                                                       cache ? &cache->impl() : nullptr);
    }
    return *glossy_;
  }

  std::shared_ptr<GatherCache> cache;  // kept alive while views point into it
  const tree::TreeSource& tree;
  gather::CutWalker walker;
  std::unique_ptr<gather::FactorizedGather> factorized;  // made on first use
  std::vector<Receiver> batch;                           // checked receivers
  std::unique_ptr<gather::GlossyGather> glossy_;
  std::shared_ptr<const VolumePoints> fog;               // set_volume_points
};

Gatherer::Gatherer(const tree::TreeSource& tree, const GatherOptions& options,
                   std::shared_ptr<GatherCache> cache) {
  options.validate();
  impl_ = std::make_unique<Impl>(tree, options, counters_, std::move(cache));
}

Gatherer::~Gatherer() = default;

void Gatherer::set_volume_points(std::shared_ptr<const VolumePoints> fog) {
  impl_->fog = fog && !fog->empty() ? std::move(fog) : nullptr;
}

void Gatherer::set_ray_scene(const RayScene* rays) { impl_->walker.set_ray_scene(rays); }

namespace {

// GatherCounters::non_finite: a result with a NaN or infinity becomes
// "nothing seen"; true if it did.
bool replace_non_finite(GatherResult& r) {
  const auto finite = [](const auto& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); };
  if (finite(r.irradiance) && std::isfinite(r.ao) && finite(r.glossy) && finite(r.bent_normal)) return false;
  r = GatherResult{};
  return true;
}

}  // namespace

GatherResult Gatherer::gather(const Receiver& receiver) {
  // Pages stay pinned until the receiver is done.
  const gather::ClearPinsOnExit unpin{impl_->walker.pins()};
  GatherResult out = gather_pinned(gather::checked_receiver(receiver));
  counters_.pages_fetched += impl_->walker.pins().take_fetches();
  counters_.non_finite += replace_non_finite(out);
  return out;
}

GatherResult Gatherer::gather_pinned(const Receiver& r) {
  gather::CutWalker& w = impl_->walker;
  // 1. The receiver and its hemisphere.
  if (w.pins().pinned() == 0) w.views().trim();  // no view is in use
  w.begin_receiver(r.position, r.normal);

  // 2. Traversal of what the receiver's air region sees.
  const uint32_t region = w.region_of(r);
  w.push_root(region);
  w.walk_receiver();
  ++counters_.receivers;

  // 3. Fog in front of (and behind) the surfaces: volume_fragments.h.
  if (impl_->fog) gather::add_volume_fragments(*impl_->fog, r.position, w.buffer());

  // 4. Visibility and convolution; a glossy receiver also convolves its
  //    unrefined pixels with the lobe here.
  if (!r.glossy.active()) {
    const gather::Resolved res = w.resolve(nullptr);
    GatherResult out;
    out.irradiance = res.irradiance;
    out.ao = res.ao;
    if (w.options().bent_normal) out.bent_normal = w.buffer().bent_normal(res);
    return out;
  }
  gather::GlossyGather& glossy = impl_->glossy();
  const gather::Resolved res = glossy.resolve(r, w, nullptr);
  GatherResult out;
  out.irradiance = res.irradiance;
  out.ao = res.ao;
  if (w.options().bent_normal) out.bent_normal = w.buffer().bent_normal(res);
  out.glossy = res.reflected + glossy.refined(r, region, counters_, impl_->fog.get());
  ++counters_.glossy_receivers;
  return out;
}

uint32_t Gatherer::region_of(const Receiver& r) const { return impl_->walker.region_of(r); }

float Gatherer::harmonic_mean_distance() const {
  return impl_->walker.buffer().harmonic_mean_distance();
}

void Gatherer::gather_tile(std::span<const Receiver> receivers, std::span<GatherResult> results) {
  if (receivers.size() != results.size()) {
    throw InvalidArgument("gather_tile: " + std::to_string(receivers.size()) + " receivers but " +
                          std::to_string(results.size()) + " results");
  }
  if (impl_->walker.options().method == GatherMethod::kPbgi) {
    // Neighbouring receivers walk nearly the same pages: they stay pinned
    // for a run of kPinRun receivers instead of being fetched again by each
    // (the TreeSource's page() and the handle's release were 5% of the
    // time). Pages are unpinned between runs and when the tile is done.
    constexpr size_t kPinRun = 64;
    gather::CutWalker& w = impl_->walker;
    const gather::HoldPinsInScope hold{w.pins()};
    for (size_t i = 0; i < receivers.size(); ++i) {
      results[i] = gather_pinned(gather::checked_receiver(receivers[i], i));
      if ((i + 1) % kPinRun == 0) {
        counters_.pages_fetched += w.pins().take_fetches();
        w.pins().clear();
      }
    }
    counters_.pages_fetched += w.pins().take_fetches();
    for (GatherResult& r : results) counters_.non_finite += replace_non_finite(r);
    return;
  }
  // Factorized: all receivers checked first, then clustered.
  std::vector<Receiver>& batch = impl_->batch;
  batch.clear();
  for (size_t i = 0; i < receivers.size(); ++i) batch.push_back(gather::checked_receiver(receivers[i], i));
  impl_->walker.views().trim();
  if (!impl_->factorized) impl_->factorized = std::make_unique<gather::FactorizedGather>(impl_->walker);
  const bool any_glossy = std::any_of(batch.begin(), batch.end(),
                                      [](const Receiver& r) { return r.glossy.active(); });
  impl_->factorized->gather(batch, results, counters_, any_glossy ? &impl_->glossy() : nullptr,
                            impl_->fog.get());
  for (GatherResult& r : results) counters_.non_finite += replace_non_finite(r);
}

}  // namespace pbgi
