#include "server/gather/surfel_bounce.h"

#include "common/errors.h"
#include "server/gather/bounce_receivers.h"
#include "server/gather/gather.h"
#include "server/gather/view_tree_gather.h"
#include "storage/tree/node_payload.h"
#include "storage/tree/payload_rounding.h"
#include "storage/tree/tree_builder.h"

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <atomic>
#include <cmath>
#include <memory>
#include <string>

namespace pbgi {

namespace {

constexpr float kInvPi = 0.31830988618f;

bool usable_normal(const Imath::V3f& n) {
  return std::isfinite(n.x) && std::isfinite(n.y) && std::isfinite(n.z) && n.length2() > 1e-20f;
}

// A built tree held as one page that add_bounces() updates between bounces
// (while no gather runs).
class OnePageTree final : public tree::TreeSource {
 public:
  explicit OnePageTree(std::shared_ptr<tree::Page> page) : page_(std::move(page)) {}
  tree::NodeRef root() const override { return {0, 0}; }
  tree::PagePtr page(uint32_t id) const override {
    if (id != 0) throw InvalidArgument("bounce tree: no page " + std::to_string(id));
    return page_;
  }

 private:
  std::shared_ptr<tree::Page> page_;
};

// Recomputes every node's payload from its surfels' radiances, children
// (later in pre-order) before parents, rounded as the tree build rounds
// every node's payload (storage/tree/payload_rounding.h).
void rebuild_payloads(tree::Page& page) {
  for (size_t i = page.nodes.size(); i-- > 0;) {
    tree::Node& n = page.nodes[i];
    tree::PayloadAccumulator acc;
    if (n.is_leaf()) {
      for (uint32_t s = n.first_surfel; s < n.first_surfel + n.surfel_count; ++s) {
        acc.add_surfel(page.surfels[s]);
      }
    } else {
      for (uint32_t c = 0; c < n.child_count; ++c) acc.add_node(page.nodes[n.children[c].index]);
    }
    acc.store(n);
    tree::round_payload(n);
  }
}

}  // namespace

void BounceOptions::validate() const {
  if (bounces < 1 || bounces > kMaxBounces) {
    throw InvalidArgument("bounces = " + std::to_string(bounces) + ": must be in [1, " +
                          std::to_string(kMaxBounces) + "]");
  }
  // The bounce gather's own fields that the config, CLI and gRPC set, named
  // as they name them.
  if (gather.microbuffer_resolution < GatherOptions::kMinMicrobufferResolution ||
      gather.microbuffer_resolution > GatherOptions::kMaxMicrobufferResolution) {
    throw InvalidArgument("bounce_microbuffer_resolution = " + std::to_string(gather.microbuffer_resolution) +
                          ": must be in [" + std::to_string(GatherOptions::kMinMicrobufferResolution) + ", " +
                          std::to_string(GatherOptions::kMaxMicrobufferResolution) + "]");
  }
  if (!(std::isfinite(gather.max_solid_angle) && gather.max_solid_angle > 0.f &&
        gather.max_solid_angle <= GatherOptions::kMaxMaxSolidAngle)) {
    throw InvalidArgument("bounce_max_solid_angle = " + std::to_string(gather.max_solid_angle) +
                          ": must be in (0, " + std::to_string(GatherOptions::kMaxMaxSolidAngle) + "] sr");
  }
  gather.validate();
  if (!(view_solid_angle >= 0.f && view_solid_angle <= kMaxViewSolidAngle)) {
    throw InvalidArgument("bounce_view_solid_angle = " + std::to_string(view_solid_angle) +
                          ": must be in [0, " + std::to_string(kMaxViewSolidAngle) + "] sr (0 = auto)");
  }
  if (receiver_stride < 1 || receiver_stride > kMaxReceiverStride) {
    throw InvalidArgument("bounce_receiver_stride = " + std::to_string(receiver_stride) + ": must be in [1, " +
                          std::to_string(kMaxReceiverStride) + "]");
  }
}

BounceGatherStats gather_bounce(const tree::TreeSource& tree, std::span<Surfel> surfels,
                                std::span<const Imath::C3f> direct, const BounceOptions& options,
                                const std::function<bool()>& cancelled) {
  if (surfels.size() != direct.size()) {
    throw InvalidArgument("gather_bounce: " + std::to_string(surfels.size()) + " surfels but " +
                          std::to_string(direct.size()) + " direct radiances");
  }
  options.validate();
  const size_t n = surfels.size();
  std::vector<Imath::C3f> irradiance(n, Imath::C3f(0.f));

  // 1. Irradiance at every surfel that reflects light, batch by batch; the
  // tree is only read meanwhile. With receiver_stride > 1 the batch's
  // representatives are gathered, the others interpolated from them, and
  // those that none fits gathered after (bounce_receivers.h).
  auto cache = std::make_shared<GatherCache>();
  struct Worker {
    std::unique_ptr<Gatherer> gatherer;            // without splatting
    std::unique_ptr<gather::ViewTreeGather> view;  // with
    std::vector<uint32_t> run;                     // reflecting surfels of the batch
    std::vector<Receiver> receivers;
    std::vector<GatherResult> results;
    std::vector<Imath::C3f> gathered;
    std::vector<uint32_t> fallback;
    BounceGatherStats stats;
  };
  tbb::enumerable_thread_specific<Worker> workers;
  std::atomic<bool> stop{false};
  const size_t batches = (n + kBounceBatch - 1) / kBounceBatch;
  const uint32_t stride = options.receiver_stride;
  tbb::parallel_for(tbb::blocked_range<size_t>(0, batches, 1), [&](const auto& range) {
    Worker& w = workers.local();
    if (options.splatting && !w.view) {
      w.view = std::make_unique<gather::ViewTreeGather>(tree, options.gather,
                                                        options.effective_view_solid_angle(), cache);
    } else if (!options.splatting && !w.gatherer) {
      w.gatherer = std::make_unique<Gatherer>(tree, options.gather, cache);
    }
    // Gathers at surfels[run[at[k]]] into w.gathered[k].
    const auto gather_at = [&](std::span<const uint32_t> at) {
      w.receivers.clear();
      for (uint32_t j : at) {
        const Surfel& s = surfels[w.run[j]];
        w.receivers.push_back({s.position, s.normal, {}, s.region});
      }
      w.results.resize(w.receivers.size());
      if (w.view) {
        w.view->gather(w.receivers, w.results);
      } else {
        w.gatherer->gather_tile(w.receivers, w.results);
      }
      w.gathered.resize(w.results.size());
      for (size_t k = 0; k < w.results.size(); ++k) w.gathered[k] = w.results[k].irradiance;
      w.stats.gathered += at.size();
    };
    for (size_t b = range.begin(); b != range.end(); ++b) {
      if (stop.load(std::memory_order_relaxed)) return;
      if (cancelled && cancelled()) {
        stop = true;
        return;
      }
      w.run.clear();
      const size_t end = std::min(n, (b + 1) * kBounceBatch);
      for (size_t i = b * kBounceBatch; i < end; ++i) {
        const Surfel& s = surfels[i];
        const Imath::C3f& a = s.albedo;
        if (!(a.x > 0.f || a.y > 0.f || a.z > 0.f) || !usable_normal(s.normal)) continue;
        w.run.push_back(uint32_t(i));
      }
      w.stats.receivers += w.run.size();
      const std::vector<uint32_t> reps = pick_representatives(surfels, w.run, stride);
      gather_at(reps);
      w.fallback.clear();
      interpolate_from_representatives(surfels, w.run, stride, reps, w.gathered, irradiance, w.fallback);
      if (w.fallback.empty()) continue;
      gather_at(w.fallback);
      w.stats.fallback += w.fallback.size();
      for (size_t k = 0; k < w.fallback.size(); ++k) irradiance[w.run[w.fallback[k]]] = w.gathered[k];
    }
  });
  if (stop) throw Cancelled("surfel bounce cancelled");
  BounceGatherStats stats;
  for (const Worker& w : workers) {
    stats.receivers += w.stats.receivers;
    stats.gathered += w.stats.gathered;
    stats.fallback += w.stats.fallback;
  }

  // 2. The new outgoing radiances.
  for (size_t i = 0; i < n; ++i) {
    Surfel& s = surfels[i];
    s.radiance = direct[i] + s.albedo * kInvPi * irradiance[i];
  }
  return stats;
}

std::vector<Surfel> add_bounces(std::vector<Surfel> surfels, const BounceOptions& options,
                                const tree::BuildOptions& build,
                                const std::function<void(uint32_t, float)>& progress,
                                const std::function<bool()>& cancelled) {
  options.validate();
  const uint32_t bounces = options.bounces;
  if (bounces == 1 || surfels.empty()) return surfels;

  // The tree is built once; bounces change radiances, hence payloads, not
  // its topology or bounds.
  tree::BuiltTree built = tree::build_tree(std::move(surfels), build);
  auto page = std::make_shared<tree::Page>();
  page->id = 0;
  page->nodes = std::move(built.nodes);
  page->surfels = std::move(built.surfels);
  std::vector<Imath::C3f> direct(page->surfels.size());
  for (size_t i = 0; i < direct.size(); ++i) direct[i] = page->surfels[i].radiance;

  const OnePageTree tree(page);
  for (uint32_t b = 1; b < bounces; ++b) {
    if (progress) progress(b, 0.f);
    // Gathers read the page; the radiances change only once all are done.
    gather_bounce(tree, page->surfels, direct, options, cancelled);
    rebuild_payloads(*page);
    if (progress) progress(b, 1.f);
  }
  return std::move(page->surfels);
}

}  // namespace pbgi
