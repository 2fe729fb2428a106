#include "server/gather/bounce_receivers.h"

#include "common/errors.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace pbgi {

std::vector<uint32_t> pick_representatives(std::span<const Surfel> surfels,
                                           std::span<const uint32_t> run, uint32_t stride) {
  if (stride == 0) throw InvalidArgument("pick_representatives: stride must be >= 1");
  std::vector<uint32_t> reps;
  reps.reserve((run.size() + stride - 1) / stride);
  for (size_t first = 0; first < run.size(); first += stride) {
    const size_t end = std::min(run.size(), first + stride);
    Imath::V3f sum(0.f);
    for (size_t j = first; j < end; ++j) sum += surfels[run[j]].position;
    const Imath::V3f centroid = sum / float(end - first);
    // The member nearest the centroid: on the surfaces, where the centroid
    // of a run over an edge is not.
    size_t best = first;
    float best_d2 = std::numeric_limits<float>::max();
    for (size_t j = first; j < end; ++j) {
      const float d2 = (surfels[run[j]].position - centroid).length2();
      if (d2 < best_d2) {
        best_d2 = d2;
        best = j;
      }
    }
    reps.push_back(uint32_t(best));
  }
  return reps;
}

void interpolate_from_representatives(std::span<const Surfel> surfels, std::span<const uint32_t> run,
                                      uint32_t stride, std::span<const uint32_t> representatives,
                                      std::span<const Imath::C3f> gathered,
                                      std::span<Imath::C3f> irradiance, std::vector<uint32_t>& fallback) {
  using L = BounceReceiverLimits;
  const size_t groups = representatives.size();
  if (stride == 0 || gathered.size() != groups || groups != (run.size() + stride - 1) / stride) {
    throw InvalidArgument("interpolate_from_representatives: " + std::to_string(groups) +
                          " representatives and " + std::to_string(gathered.size()) +
                          " irradiances for a run of " + std::to_string(run.size()) + " at stride " +
                          std::to_string(stride));
  }
  const float reach_per_radius = L::kReach * std::sqrt(float(stride));
  for (size_t g = 0; g < groups; ++g) {
    irradiance[run[representatives[g]]] = gathered[g];
  }
  for (size_t j = 0; j < run.size(); ++j) {
    const size_t g = j / stride;
    if (representatives[g] == j) continue;
    const Surfel& s = surfels[run[j]];
    const float reach = reach_per_radius * s.radius;
    const float reach2 = reach * reach;
    const float max_offset = L::kMaxPlaneOffset * reach;
    Imath::C3f sum(0.f);
    float weights = 0.f;
    for (size_t h = g == 0 ? 0 : g - 1; h <= std::min(groups - 1, g + 1); ++h) {
      const Surfel& r = surfels[run[representatives[h]]];
      const float cosine = s.normal.dot(r.normal);
      if (!(cosine > L::kMaxNormalAngleCos)) continue;
      const Imath::V3f d = r.position - s.position;
      const float d2 = d.length2();
      const float offset = std::abs(s.normal.dot(d));
      if (!(d2 < reach2) || !(offset < max_offset)) continue;
      // Each factor falls to 0 at its limit: no jump where a
      // representative stops counting.
      const float falloff = 1.f - d2 / reach2;
      const float w = (cosine - L::kMaxNormalAngleCos) / (1.f - L::kMaxNormalAngleCos) * falloff * falloff *
                      (1.f - offset / max_offset);
      sum += gathered[h] * w;
      weights += w;
    }
    if (weights > 0.f) {
      irradiance[run[j]] = sum / weights;
    } else {
      fallback.push_back(uint32_t(j));
    }
  }
}

}  // namespace pbgi
