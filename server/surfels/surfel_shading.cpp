#include "server/scene/direct_lighting.h"
#include "server/scene/rng.h"
#include "server/scene/sample_patterns.h"
#include "server/surfels/progress_meter.h"
#include "server/surfels/surfels.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace pbgi {
namespace {
constexpr uint64_t kShadeDomain = 0x7368616465ull;  // "shade"

void shade(const RayScene& rays, const SurfelOptions& options, std::span<Surfel> surfels, uint64_t first_index,
           ProgressMeter* meter) {
  tbb::parallel_for(tbb::blocked_range<size_t>(0, surfels.size(), 256), [&](const auto& r) {
    for (size_t i = r.begin(); i != r.end(); ++i) {
      Surfel& s = surfels[i];
      if (s.albedo.x <= 0.f && s.albedo.y <= 0.f && s.albedo.z <= 0.f) continue;
      const C3f e = direct_irradiance(rays, s.position, s.normal, options.light_samples,
                                      hash_ids(options.seed, kShadeDomain, first_index + i));
      s.radiance += s.albedo * e * kInvPi;
    }
    if (meter) meter->advance(r.size());
  });
}
}  // namespace

// Each surfel's light samples come from a generator seeded by (seed, its
// index), so the result does not depend on the thread schedule. The surfel
// lies on its surface; direct_irradiance offsets the shadow-ray origins.
void shade_direct(const RayScene& rays, const SurfelOptions& options,
                  std::vector<Surfel>& surfels, const ProgressFn& progress) {
  options.validate();
  ProgressMeter meter(progress, "shade_direct", surfels.size());
  shade(rays, options, surfels, 0, &meter);
  meter.finish();
}

void shade_direct(const RayScene& rays, const SurfelOptions& options, std::span<Surfel> surfels,
                  uint64_t first_index) {
  shade(rays, options, surfels, first_index, nullptr);
}

}  // namespace pbgi
