#include "server/service/interpolated_gather.h"

#include "server/gather/irradiance_cache.h"
#include "server/gather/receiver_check.h"
#include "storage/tree/morton.h"

#include <algorithm>
#include <array>
#include <bit>
#include <chrono>
#include <cstdint>
#include <optional>
#include <tuple>

namespace pbgi::service {
namespace {

using Imath::V3f;

// Gathered share of the pending receivers per round: 1/64 as the coarsest
// (about one per 8 x 8 pixels of a tile's shading points), then denser
// where no record reached.
constexpr std::array<size_t, 4> kRoundStrides{64, 16, 4, 1};

// The diffuse receivers' indices along a Morton curve over their bounding
// box; ties (receivers in one cell of 2^-21 of the box) by the bits of
// position and normal, so the order depends on the set of receivers only.
std::vector<uint32_t> morton_order(const std::vector<Receiver>& receivers, const std::vector<uint32_t>& indices) {
  V3f lo(INFINITY), hi(-INFINITY);
  for (const uint32_t i : indices) {
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], receivers[i].position[a]);
      hi[a] = std::max(hi[a], receivers[i].position[a]);
    }
  }
  const float extent = std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z});
  const float scale = extent > 0.f ? float((1u << 21) - 1) / extent : 0.f;
  using Key = std::tuple<uint64_t, std::array<uint32_t, 6>, uint32_t>;
  std::vector<Key> keys;
  keys.reserve(indices.size());
  for (const uint32_t i : indices) {
    const Receiver& r = receivers[i];
    uint64_t code = 0;
    for (int a = 0; a < 3; ++a) {
      const uint32_t q = uint32_t(std::clamp((r.position[a] - lo[a]) * scale, 0.f, float((1u << 21) - 1)));
      code |= tree::spread_bits_3(q) << a;
    }
    const std::array<uint32_t, 6> bits{std::bit_cast<uint32_t>(r.position.x), std::bit_cast<uint32_t>(r.position.y),
                                       std::bit_cast<uint32_t>(r.position.z), std::bit_cast<uint32_t>(r.normal.x),
                                       std::bit_cast<uint32_t>(r.normal.y),   std::bit_cast<uint32_t>(r.normal.z)};
    // The index only orders identical receivers, whose results are equal.
    keys.emplace_back(code, bits, i);
  }
  std::sort(keys.begin(), keys.end());
  std::vector<uint32_t> out;
  out.reserve(keys.size());
  for (const Key& k : keys) out.push_back(std::get<2>(k));
  return out;
}

}  // namespace

GatherBatch gather_interpolated(const tree::TreeSource& tree, const std::vector<Receiver>& receivers,
                                const GatherOptions& options, float tolerance, const std::function<bool()>& cancelled,
                                std::shared_ptr<const VolumePoints> fog, const RayScene* rays) {
  const auto start = std::chrono::steady_clock::now();
  IrradianceCache cache(tolerance);  // checks the tolerance

  // 1. Checked receivers (unit normals), glossy ones apart.
  std::vector<Receiver> checked(receivers.size());
  std::vector<uint32_t> glossy, diffuse;
  for (size_t i = 0; i < receivers.size(); ++i) {
    checked[i] = gather::checked_receiver(receivers[i], i);
    (checked[i].glossy.active() ? glossy : diffuse).push_back(uint32_t(i));
  }
  std::vector<uint32_t> pending = morton_order(checked, diffuse);

  GatherBatch batch;
  batch.results.resize(receivers.size());
  GatherPool pool(tree, options, cancelled, std::move(fog), rays);
  std::vector<float> radius(receivers.size(), 0.f);
  // Each receiver's air region: records are taken only within one.
  std::vector<uint32_t> region(receivers.size(), 0);
  pool.for_each(receivers.size(), [&](Gatherer& gatherer, size_t i) { region[i] = gatherer.region_of(checked[i]); });
  std::vector<uint8_t> found;
  std::vector<uint32_t> gather, misses;
  for (size_t round = 0; round < kRoundStrides.size(); ++round) {
    if (round > 0 && pending.empty()) break;
    // 2. Pending receivers take the records of earlier rounds where valid.
    if (cache.size() > 0) {
      found.assign(pending.size(), 0);
      pool.for_each(pending.size(), [&](size_t j) {
        const Receiver& r = checked[pending[j]];
        if (std::optional<GatherResult> mix = cache.interpolate(r.position, r.normal, region[pending[j]])) {
          batch.results[pending[j]] = *mix;
          found[j] = 1;
        }
      });
      misses.clear();
      for (size_t j = 0; j < pending.size(); ++j) {
        if (!found[j]) misses.push_back(pending[j]);
      }
      pending.swap(misses);
    }

    // 3. Every stride-th receiver still pending is gathered (and, first,
    //    every glossy one); the gathered diffuse ones become records.
    const size_t stride = kRoundStrides[round];
    gather.clear();
    if (round == 0) gather = glossy;
    const size_t first_diffuse = gather.size();
    misses.clear();
    for (size_t j = 0; j < pending.size(); ++j) (j % stride == 0 ? gather : misses).push_back(pending[j]);
    pending.swap(misses);
    pool.for_each(gather.size(), [&](Gatherer& gatherer, size_t j) {
      const uint32_t i = gather[j];
      // The request's receiver: exactly the gather it gets without
      // interpolation (checking normalizes its normal again).
      batch.results[i] = gatherer.gather(receivers[i]);
      if (j >= first_diffuse) radius[i] = gatherer.harmonic_mean_distance();
    });
    for (size_t j = first_diffuse; j < gather.size(); ++j) {
      const uint32_t i = gather[j];
      cache.add({checked[i].position, checked[i].normal, radius[i], batch.results[i], region[i]});
    }
    cache.build();
  }

  batch.counters = pool.counters();  // counters.receivers: the gathers
  batch.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return batch;
}

}  // namespace pbgi::service
