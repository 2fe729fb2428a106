#include "server/surfels/surfel_gloss_lookup.h"

#include "server/scene/surface_colors.h"
#include "server/surfels/surfel_material.h"
#include "storage/tree/page_records.h"

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
      // From just above the surfel (its rounding box, as a ray leaving it,
      // and how far decoding may have moved it off its surface:
      // storage/tree/page_records.h) down the normal, as far again below it.
      const V3f err = rays.point_error(s.position);
      const float offset = 4.f * std::max({err.x, err.y, err.z}) + storage::kDecodedPositionSlack * s.radius;
      const V3f origin = s.position + s.normal * offset;
      // The surfel's own triangle faces its way (its winding normal is the
      // surfel's, or the opposite for the back of a double-sided mesh): a
      // coincident surface facing the other way (a box's bottom on a
      // floor) is passed through. It lies at the same distance as the
      // surfel's own triangle, so it is rejected inside the traversal, not
      // stepped over: which of the two Embree meets first depends on its ISA.
      const Hit hit = rays.intersect(origin, -s.normal, 0.f, 2.f * offset, [&](const Hit& h) {
        const float facing = h.geometric_normal.dot(s.normal);
        return facing > kParallelCos || (facing < -kParallelCos && scene.triangle(h.triangle).double_sided());
      });
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
