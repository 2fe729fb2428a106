#include "server/gather/receiver_clusters.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace pbgi::gather {

void ReceiverClusters::build(std::span<const Receiver> rs, uint32_t k, uint32_t iterations) {
  clusters_.clear();
  members_.clear();
  const uint32_t n = uint32_t(rs.size());
  if (n == 0) return;
  k = std::clamp<uint32_t>(k, 1, n);

  // 1. Relative positions, the metric's alpha.
  const Imath::V3f origin = rs[0].position;
  pos_.resize(n);
  Imath::V3f lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
  for (uint32_t i = 0; i < n; ++i) {
    pos_[i] = rs[i].position - origin;
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], pos_[i][a]);
      hi[a] = std::max(hi[a], pos_[i][a]);
    }
  }
  const float diag2 = (hi - lo).length2();
  const float alpha = diag2 > 0.f ? diag2 : 1.f;

  // 2. Lloyd iterations from evenly spread receivers.
  center_p_.resize(k);
  center_n_.resize(k);
  for (uint32_t c = 0; c < k; ++c) {
    const uint32_t i = uint32_t((uint64_t(2 * c + 1) * n) / (2 * uint64_t(k)));
    center_p_[c] = pos_[i];
    center_n_[c] = rs[i].normal;
  }
  assign_.resize(n);
  const auto assign_all = [&] {
    for (uint32_t i = 0; i < n; ++i) {
      const Imath::V3f& p = pos_[i];
      const Imath::V3f& nn = rs[i].normal;
      float best = std::numeric_limits<float>::max();
      uint32_t arg = 0;
      for (uint32_t c = 0; c < k; ++c) {
        const float d = (p - center_p_[c]).length2() + alpha * (nn - center_n_[c]).length2();
        if (d < best) {
          best = d;
          arg = c;
        }
      }
      assign_[i] = arg;
    }
  };
  sum_p_.resize(k);
  sum_n_.resize(k);
  size_.resize(k);
  for (uint32_t it = 0; it < iterations; ++it) {
    assign_all();
    std::fill(sum_p_.begin(), sum_p_.end(), Imath::V3f(0));
    std::fill(sum_n_.begin(), sum_n_.end(), Imath::V3f(0));
    std::fill(size_.begin(), size_.end(), 0u);
    for (uint32_t i = 0; i < n; ++i) {
      sum_p_[assign_[i]] += pos_[i];
      sum_n_[assign_[i]] += rs[i].normal;
      ++size_[assign_[i]];
    }
    for (uint32_t c = 0; c < k; ++c) {
      if (size_[c] == 0) continue;  // keeps its center; may win members back
      center_p_[c] = sum_p_[c] / float(size_[c]);
      const float len = sum_n_[c].length();
      if (len > 1e-6f) center_n_[c] = sum_n_[c] / len;
    }
  }
  assign_all();

  // 3. Members grouped by cluster (counting sort).
  std::fill(size_.begin(), size_.end(), 0u);
  for (uint32_t i = 0; i < n; ++i) ++size_[assign_[i]];
  offset_.assign(k + 1, 0);
  for (uint32_t c = 0; c < k; ++c) offset_[c + 1] = offset_[c] + size_[c];
  members_.resize(n);
  std::fill(sum_n_.begin(), sum_n_.end(), Imath::V3f(0));
  {
    std::vector<uint32_t>& cursor = size_;  // reused
    for (uint32_t c = 0; c < k; ++c) cursor[c] = offset_[c];
    for (uint32_t i = 0; i < n; ++i) members_[cursor[assign_[i]]++] = i;
  }

  // 4. Active receiver and bounds of each non-empty cluster.
  for (uint32_t c = 0; c < k; ++c) {
    const uint32_t first = offset_[c], count = offset_[c + 1] - offset_[c];
    if (count == 0) continue;
    ReceiverCluster out;
    out.first = first;
    out.count = count;
    float best = std::numeric_limits<float>::max();
    Imath::V3f nsum(0);
    for (uint32_t m = first; m < first + count; ++m) {
      const uint32_t i = members_[m];
      const float d = (pos_[i] - center_p_[c]).length2() +
                      alpha * (rs[i].normal - center_n_[c]).length2();
      if (d < best) {
        best = d;
        out.active = i;
      }
      nsum += rs[i].normal;
    }
    ClusterFrame& f = out.frame;
    f.p = rs[out.active].position;
    const float len = nsum.length();
    f.n = len > 1e-6f ? nsum / len : rs[out.active].normal;
    float radius2 = 0.f, chord2 = 0.f;
    for (uint32_t m = first; m < first + count; ++m) {
      const uint32_t i = members_[m];
      radius2 = std::max(radius2, (pos_[i] - pos_[out.active]).length2());
      chord2 = std::max(chord2, (rs[i].normal - f.n).length2());
    }
    // Rounded up a hair: the bounds must hold for every member.
    f.radius = std::sqrt(radius2) * 1.0001f;
    f.normal_chord = std::min(2.f, std::sqrt(chord2) * 1.0001f + 1e-7f);
    f.normal_angle = chord2 > 0.f ? 2.f * std::asin(std::min(1.f, 0.5f * f.normal_chord)) : 0.f;
    clusters_.push_back(out);
  }
}

}  // namespace pbgi::gather
