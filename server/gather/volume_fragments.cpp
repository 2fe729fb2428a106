#include "server/gather/volume_fragments.h"

#include <algorithm>
#include <cmath>

namespace pbgi::gather {

uint64_t add_volume_fragments(const VolumePoints& fog, const Imath::V3f& p, Microbuffer& buffer, float max_distance) {
  if (fog.empty()) return 0;
  const CubeLayout& layout = buffer.layout();
  // Slices never share a depth band with each other (see the header).
  const float ratio = 1.f + 2.f * buffer.depth_band();
  const float step = 0.5f * fog.block_size();
  // The first slice ends one step out: depths below it are one band anyway.
  const float first_end = step;
  uint64_t added = 0;
  for (uint32_t k = 0; k < layout.pixel_count(); ++k) {
    if (!buffer.in_hemisphere(k)) continue;
    const Imath::V3f d = layout.direction(k);
    float t0 = 0.f, t1 = max_distance > 0.f ? max_distance : 1e30f;
    if (!clip_to_box(fog.bounds(), p, d, t0, t1)) continue;
    const int steps = std::max(1, int(std::ceil((t1 - t0) / step)));
    const float dt = (t1 - t0) / float(steps);
    // One slice: optical depth, and in-scattered light reaching its near
    // end (each step's emission sigma_t S dt attenuated by the slice in front).
    float slice_tau = 0.f, slice_near = t0, slice_end = std::max(first_end, t0 * ratio);
    Imath::C3f slice_light(0, 0, 0);
    auto flush = [&](float far) {
      if (slice_tau > 0.f) {
        const float alpha = 1.f - std::exp(-slice_tau);
        const float w = alpha * buffer.weight(k);
        if (alpha > 1e-6f && w > 0.f) {
          buffer.add_coverage(k, 0.5f * (slice_near + far), 0.5f * (slice_near + far), alpha, w, slice_light / alpha);
          ++added;
        }
      }
      slice_tau = 0.f;
      slice_light = Imath::C3f(0, 0, 0);
      slice_near = far;
    };
    for (int i = 0; i < steps; ++i) {
      const float t = t0 + (float(i) + 0.5f) * dt;
      if (t > slice_end) {
        flush(t - 0.5f * dt);
        slice_end = std::max(slice_end * ratio, t);
      }
      const VolumePoint* v = fog.at(p + d * t);
      if (!v || !(v->sigma_t > 0.f)) continue;
      const float tau = v->sigma_t * dt;
      // Emission of the step, seen through the slice's fog in front of it
      // (integrated exactly over the step: (1 - e^-tau) S).
      slice_light += v->radiance * (std::exp(-slice_tau) * (1.f - std::exp(-tau)));
      slice_tau += tau;
    }
    flush(t1);
  }
  return added;
}

}  // namespace pbgi::gather
