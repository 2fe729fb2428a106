#include "server/surfels/surfel_gloss_lookup.h"

#include "server/scene/surface_colors.h"
#include "server/surfels/surfel_material.h"

#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

namespace pbgi {

namespace {

// The triangle a surfel lies on is parallel to it within this cosine: a
// surfel's normal is its triangle's geometric normal (or its opposite for
// the back side of a double-sided mesh), up to rounding.
constexpr float kParallelCos = 0.999f;
// Surfaces within the surfel's offset passed through before giving up.
constexpr int kMaxCoincident = 4;

}  // namespace

GlossLookupStats restore_surfel_gloss(const RayScene& rays, float glossy_roughness,
                                      std::span<Surfel> surfels) {
  const Scene& scene = rays.scene();
  tbb::combinable<GlossLookupStats> counts;
  tbb::parallel_for(tbb::blocked_range<size_t>(0, surfels.size(), 1024), [&](const auto& range) {
    GlossLookupStats& c = counts.local();
    for (size_t i = range.begin(); i != range.end(); ++i) {
      Surfel& s = surfels[i];
      s.gloss = {};
      if (!(glossy_roughness > 0.f)) continue;
      // From just above the surfel (its rounding box, as a ray leaving it)
      // down the normal, as far again below it.
      const V3f err = rays.point_error(s.position);
      const float offset = 4.f * std::max({err.x, err.y, err.z}) + 1e-3f * s.radius;
      const V3f origin = s.position + s.normal * offset;
      // The surfel's own triangle faces its way (its winding normal is the
      // surfel's, or the opposite for the back of a double-sided mesh):
      // a coincident surface facing the other way (a box's bottom on a
      // floor) is passed through.
      Hit hit;
      float tmin = 0.f;
      for (int tries = 0; tries < kMaxCoincident; ++tries) {
        hit = rays.intersect(origin, -s.normal, tmin, 2.f * offset);
        if (!hit.valid()) break;
        const float facing = hit.geometric_normal.dot(s.normal);
        if (facing > kParallelCos || (facing < -kParallelCos && scene.triangle(hit.triangle).double_sided())) break;
        tmin = std::nextafter(hit.t, 2.f * offset);
        hit = Hit{};
      }
      if (!hit.valid()) {
        ++c.missed;
        continue;
      }
      const SurfaceColors colors = surface_colors(scene, hit.triangle, hit.u, hit.v, 2.f * s.radius);
      Surfel found = s;
      set_surfel_material(scene, hit.triangle, colors, glossy_roughness, found);
      s.gloss = found.gloss;
      if (s.gloss.glossy()) ++c.glossy;
    }
  });
  GlossLookupStats out;
  counts.combine_each([&](const GlossLookupStats& c) {
    out.glossy += c.glossy;
    out.missed += c.missed;
  });
  return out;
}

}  // namespace pbgi
