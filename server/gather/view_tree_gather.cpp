#include "server/gather/view_tree_gather.h"

#include "common/errors.h"
#include "server/gather/receiver_check.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <limits>

namespace pbgi::gather {

namespace {

constexpr float kPi = 3.14159265358979f;
// The largest view solid angle: FPBGI's largest epsilon (0.5) as a cap.
constexpr float kMaxViewSolidAngle = kPi * GatherOptions::kMaxEpsilon * GatherOptions::kMaxEpsilon;

float checked_epsilon(float view_solid_angle) {
  if (!(view_solid_angle > 0.f && view_solid_angle <= kMaxViewSolidAngle)) {
    throw InvalidArgument("view_solid_angle = " + std::to_string(view_solid_angle) + ": must be in (0, " +
                          std::to_string(kMaxViewSolidAngle) + "] sr");
  }
  return std::sqrt(view_solid_angle / kPi);
}

}  // namespace

ViewTreeGather::ViewTreeGather(const tree::TreeSource& tree, const GatherOptions& options,
                               float view_solid_angle, std::shared_ptr<GatherCache> cache)
    : cache_(std::move(cache)),
      walker_(tree, (options.validate(), options), counters_, cache_ ? &cache_->impl() : nullptr),
      epsilon_(checked_epsilon(view_solid_angle)) {}

ViewTreeGather::~ViewTreeGather() = default;

ClusterFrame ViewTreeGather::frame_of(uint32_t first, uint32_t count) const {
  Imath::V3f psum(0), nsum(0);
  for (uint32_t i = first; i < first + count; ++i) {
    psum += receivers_[i].position;
    nsum += receivers_[i].normal;
  }
  ClusterFrame f;
  // Far content is drawn from the member nearest the centroid (FPBGI's
  // active receiver): a point on the surfaces, where the centroid of a run
  // over an edge lies off them.
  const Imath::V3f centroid = psum / float(count);
  float best = std::numeric_limits<float>::max();
  for (uint32_t i = first; i < first + count; ++i) {
    const float d2 = (receivers_[i].position - centroid).length2();
    if (d2 < best) {
      best = d2;
      f.p = receivers_[i].position;
    }
  }
  const float len = nsum.length();
  // Opposite normals (both faces of a thin wall) average to nothing: any
  // axis does, the chord then bounds the spread.
  f.n = len > 1e-6f ? nsum / len : receivers_[first].normal;
  float radius2 = 0.f, chord2 = 0.f;
  for (uint32_t i = first; i < first + count; ++i) {
    radius2 = std::max(radius2, (receivers_[i].position - f.p).length2());
    chord2 = std::max(chord2, (receivers_[i].normal - f.n).length2());
  }
  // Rounded up a hair: the bounds must hold for every member (as
  // receiver_clusters.cpp does).
  f.radius = std::sqrt(radius2) * 1.0001f;
  f.normal_chord = std::min(2.f, std::sqrt(chord2) * 1.0001f + 1e-7f);
  f.normal_angle = chord2 > 0.f ? 2.f * std::asin(std::min(1.f, 0.5f * f.normal_chord)) : 0.f;
  return f;
}

void ViewTreeGather::gather(std::span<const Receiver> receivers, std::span<GatherResult> results) {
  if (receivers.size() != results.size()) {
    throw InvalidArgument("view-tree gather: " + std::to_string(receivers.size()) + " receivers but " +
                          std::to_string(results.size()) + " results");
  }
  // Each run of receivers of one air region walks that region's subtree
  // (receivers arrive sorted by region, as a page set's surfels are).
  size_t first = 0;
  uint32_t region = receivers.empty() ? tree::kAnyRegion : walker_.region_of(receivers[0]);
  for (size_t i = 1; i <= receivers.size(); ++i) {
    const uint32_t next = i < receivers.size() ? walker_.region_of(receivers[i]) : region;
    if (i < receivers.size() && next == region) continue;
    gather_region(receivers.subspan(first, i - first), results.subspan(first, i - first), region, first);
    first = i;
    region = next;
  }
}

void ViewTreeGather::gather_region(std::span<const Receiver> receivers, std::span<GatherResult> results,
                                   uint32_t region, size_t offset) {
  receivers_.clear();
  for (size_t i = 0; i < receivers.size(); ++i) {
    Receiver r = checked_receiver(receivers[i], offset + i);
    r.glossy = {};
    receivers_.push_back(r);
  }
  if (receivers_.empty()) return;

  // Pages stay pinned for the whole batch: the receiver hierarchy revisits
  // them from every node. Unpinned when done (and on errors).
  PagePins& pins = walker_.pins();
  // One far buffer and near list per level of the receiver hierarchy,
  // made before the recursion holds references into them.
  uint32_t levels = 1;
  for (size_t n = receivers_.size(); n > kLeafReceivers; n = (n + 1) / 2) ++levels;
  const GatherOptions& o = walker_.options();
  while (far_.size() < levels) {
    far_.push_back(std::make_unique<FarBuffer>(CubeLayout::get(o.microbuffer_resolution), depth_band_for(o)));
    near_.emplace_back();
  }
  walker_.views().trim();
  const HoldPinsInScope hold{pins};
  walker_.push_root(region);
  gather_node(0, uint32_t(receivers_.size()), 0, {}, results);
  counters_.pages_fetched += pins.take_fetches();
}

void ViewTreeGather::gather_node(uint32_t first, uint32_t count, uint32_t level,
                                 std::span<const StackEntry> from, std::span<GatherResult> results) {
  const GatherOptions& o = walker_.options();
  FarBuffer& far = *far_[level];
  // Far content of the enclosing receiver nodes holds for this one too:
  // its surfels lie within theirs.
  if (level == 0) {
    far.begin();
  } else {
    far.begin_from(*far_[level - 1]);
  }
  std::vector<StackEntry>& near = near_[level];
  near.clear();
  // 1. Sender nodes far from this receiver node go into its far buffer;
  //    near ones are kept for the children (level 0 starts at the root,
  //    pushed by gather()).
  const ClusterFrame frame = frame_of(first, count);
  walker_.walk_cluster(frame, epsilon_, from, far, near);

  if (count > kLeafReceivers) {
    // 2. Refine on the receiver side: both halves of the Morton run.
    const uint32_t half = count / 2;
    gather_node(first, half, level + 1, near, results);
    gather_node(first + half, count - half, level + 1, near, results);
  } else {
    // 3. A receiver leaf: the shared far content is resolved once, each
    //    surfel refines the near senders in its own microbuffer.
    far.resolve(o.ao_max_distance);
    for (uint32_t i = first; i < first + count; ++i) {
      const Receiver& r = receivers_[i];
      walker_.begin_receiver(r.position, r.normal);
      for (size_t j = near.size(); j-- > 0;) walker_.push(near[j]);
      walker_.walk_receiver();
      const Resolved res = walker_.resolve(&far);
      results[i].irradiance = res.irradiance;
      results[i].ao = res.ao;
      results[i].glossy = Imath::C3f(0.f);
      ++counters_.receivers;
    }
  }
  PagePins& pins = walker_.pins();
  for (const StackEntry& e : near) pins.release(e.pin);
}

}  // namespace pbgi::gather
