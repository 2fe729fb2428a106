#include "server/gather/result_mix.h"

#include <algorithm>

namespace pbgi {

GatherResult mix_results(std::span<const GatherResult* const> results, std::span<const float> weights) {
  GatherResult out;
  out.ao = 0.f;
  float sum = 0.f;
  const size_t n = std::min(results.size(), weights.size());
  for (size_t i = 0; i < n; ++i) {
    if (weights[i] <= 0.f) continue;
    sum += weights[i];
    out.irradiance += weights[i] * results[i]->irradiance;
    out.ao += weights[i] * results[i]->ao;
    out.glossy += weights[i] * results[i]->glossy;
    out.bent_normal += weights[i] * results[i]->bent_normal;
  }
  const float inv = 1.f / sum;
  out.irradiance *= inv;
  out.ao *= inv;
  out.glossy *= inv;
  const float len = out.bent_normal.length();
  out.bent_normal = len > 0.f ? out.bent_normal / len : Imath::V3f(0.f);
  return out;
}

}  // namespace pbgi
