// Uniform-density surfel sampling.
//
// Every triangle gets n = floor(A / s^2 + u) surfels (u uniform, drawn from a
// generator seeded by the triangle's index), so the expected count is A/s^2
// whatever the tessellation. Inside a triangle the n positions are the first
// n points of a randomly shifted R2 sequence mapped to the triangle with
// Heitz's low-distortion map: evenly spread, no clumps on large triangles.
//
// Area is conserved exactly (up to float rounding), not just in
// expectation: a triangle that draws no surfel hands its area on to the
// next triangle of the same mesh that draws some, whose surfels share it;
// area left over at the end of a mesh goes to the last surfel-bearing
// triangle of that mesh, and a mesh too small to draw any surfel gets one on
// its largest triangle. Each surfel's disk has the area it stands for
// (radius = sqrt(share / pi)), so the surfel areas sum to the scene's area.
//
// Coincident coplanar copies (a duplicated wall) are one surface to the
// renderers: a surfel whose point is covered by k coincident pieces
// (coincident_surfaces.h: same plane within 1% of the spacing, same facing)
// stands for 1/k of its share, so the copies' area is counted once. The
// copies keep their surfels (the density there is k times the usual one,
// each surfel smaller).
//
// Double-sided meshes reflect light on both faces: each of their samples
// yields two surfels at the same point with opposite normals, each standing
// for the full area of its face (the area sum then counts those meshes
// twice; the spacing derived from target_surfels accounts for it).
//
// Triangles with zero, negative or non-finite area are skipped and counted.
//
// Streaming: the scene is sampled range by range (triangle_ranges.h: the
// world soup, then each instance in order). Per range, the per-triangle
// plan (counts, shares, offsets) is computed first; surfels are then
// produced chunk by chunk of the range's surfel index, each surfel from its
// triangle's plan alone, so a chunk boundary may fall inside a triangle and
// no chunk depends on another. The plan is per triangle of the range's soup,
// so memory follows the world soup and the largest prototype, not the
// number of instances (before: 24 bytes per triangle with instances
// expanded). Every random stream is still keyed by the scene triangle id,
// and area shares are per mesh, which never spans two ranges: the surfels
// are those of the scene flattened, in the same order.
//
// Coincident copies are found within a range: the world soup's triangles
// among themselves (in world space), and a prototype's among themselves
// (once per prototype, in its own space, the plane tolerance divided by
// the geometric mean of its instances' linear scales: coplanarity and
// overlap survive an invertible affine map). Copies split across ranges --
// two instances placed on top of each other, or an instance over world
// geometry -- are found by one more cover, in world space, over the
// triangles lying where two ranges' bounds meet (cross_range_cover.h); a
// surfel's point then counts the larger of the two covers.
//
// Albedo and emission come from the triangle's material; a textured or
// vertex-coloured one is evaluated at each surfel's point
// (server/scene/surface_colors.h), with textures averaged over a square of
// the surfel's area, so that the surfels of a mesh keep the texture's mean.
#include "common/errors.h"
#include "server/scene/rng.h"
#include "server/scene/sample_patterns.h"
#include "server/scene/scene_bulk.h"
#include "server/scene/scene_validation.h"
#include "server/scene/surface_colors.h"
#include "server/scene/surface_opacity.h"
#include "server/surfels/coincident_surfaces.h"
#include "server/surfels/cross_range_cover.h"
#include "server/surfels/progress_meter.h"
#include "server/surfels/surfel_material.h"
#include "server/surfels/surfel_samplers.h"
#include "server/surfels/triangle_ranges.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

namespace pbgi {
namespace {

// Domain-separation constants: sampling and shading draw from unrelated
// streams even for the same index.
constexpr uint64_t kCountDomain = 0x636f756e74ull;   // "count"
constexpr uint64_t kPlaceDomain = 0x706c616365ull;   // "place"

// Surfels produced per chunk handed to the sink.
constexpr uint64_t kChunk = 65536;
// Coincident pieces: planes closer than this fraction of the spacing.
constexpr float kCoplanarTolerance = 0.01f;

struct TrianglePlan {
  float area = 0.f;       // one face; 0 = skipped
  uint32_t count = 0;     // samples (twins not counted)
  float share = 0.f;      // area each of its surfels stands for
  uint64_t first = 0;     // index of its first surfel within the range
};

// Steps 1, 3 and 4 of sample_uniform() for one range: areas, sample
// counts (each from the generator of its scene triangle id), area shares
// per mesh and the surfel layout. Returns the range's surfel count.
uint64_t plan_range(const TriangleRange& range, double s2, uint64_t seed, std::vector<TrianglePlan>& plan) {
  const size_t tris = range.size();
  plan.assign(tris, TrianglePlan{});
  tbb::parallel_for(tbb::blocked_range<size_t>(0, tris, 4096), [&](const auto& r) {
    for (size_t i = r.begin(); i != r.end(); ++i) {
      TrianglePlan& p = plan[i];
      p.area = range.area(uint32_t(i));
      Rng rng(hash_ids(seed, kCountDomain, uint64_t(range.first_id) + i));
      p.count = static_cast<uint32_t>(std::floor(p.area / s2 + rng.uniform()));
    }
  });

  // Area shares, serially per mesh of the range's soup (meshes never span
  // two ranges).
  const TriangleSoup& soup = *range.soup;
  const size_t meshes = std::max<size_t>(soup.mesh_paths.size(), 1);
  std::vector<double> pending(meshes, 0.0);
  std::vector<int64_t> last(meshes, -1), largest(meshes, -1);
  for (size_t i = 0; i < tris; ++i) {
    const size_t m = soup.mesh.empty() ? 0 : soup.mesh[i];
    TrianglePlan& p = plan[i];
    if (p.area == 0.f) continue;
    if (largest[m] < 0 || p.area > plan[largest[m]].area) largest[m] = static_cast<int64_t>(i);
    if (p.count == 0) {
      pending[m] += p.area;
      continue;
    }
    p.share = static_cast<float>((p.area + pending[m]) / p.count);
    pending[m] = 0.0;
    last[m] = static_cast<int64_t>(i);
  }
  for (size_t m = 0; m < meshes; ++m) {
    if (!(pending[m] > 0.0)) continue;
    if (last[m] >= 0) {
      TrianglePlan& p = plan[last[m]];
      p.share = static_cast<float>(p.share + pending[m] / p.count);
    } else {
      TrianglePlan& p = plan[largest[m]];
      p.count = 1;
      p.share = static_cast<float>(pending[m]);
    }
  }
  uint64_t total = 0;
  for (size_t i = 0; i < tris; ++i) {
    plan[i].first = total;
    total += static_cast<uint64_t>(plan[i].count) * (range.double_sided(uint32_t(i)) ? 2 : 1);
  }
  return total;
}

// Step 5 for the triangles of one soup: its coincident coplanar pieces,
// in world space (the world soup) or in the soup's own space (a
// prototype: coincidence is the same in every placement; the caller
// scales the tolerance). Degenerate triangles cover nothing.
CoincidentCover soup_cover(const TriangleSoup& soup, const V3f& centre, float plane_tolerance) {
  const TriangleRange range{&soup, nullptr, 0};
  auto piece = [&](uint32_t i, PlanarPiece* out) {
    if (!(range.area(i) > 0.f)) return false;
    const TriangleRef r = range.triangle(i);
    return PlanarPiece::of_triangle(r.position(0), r.position(1), r.position(2), out);
  };
  return CoincidentCover(range.size(), piece, centre, plane_tolerance);
}

// Per prototype, its cover (prototype space). The plane tolerance is the
// world one over the geometric mean of its instances' linear scales
// (cbrt |det|); prototypes without instances get none.
std::vector<CoincidentCover> prototype_covers(const Scene& scene, float world_tolerance) {
  std::vector<double> log_scale(scene.prototypes.size(), 0.0);
  std::vector<uint32_t> uses(scene.prototypes.size(), 0);
  for (const Instance& inst : scene.instances) {
    log_scale[inst.prototype] += std::log(std::fabs(double(inst.local_to_world.determinant()))) / 3.0;
    ++uses[inst.prototype];
  }
  std::vector<CoincidentCover> covers(scene.prototypes.size());
  for (size_t p = 0; p < scene.prototypes.size(); ++p) {
    if (uses[p] == 0) continue;
    const TriangleSoup& soup = scene.prototypes[p].triangles;
    Box3f box;
    for (const V3f& v : soup.positions) box.extendBy(v);
    const float scale = float(std::exp(log_scale[p] / uses[p]));
    covers[p] = soup_cover(soup, box.isEmpty() ? V3f(0.f) : box.center(), world_tolerance / scale);
  }
  return covers;
}

// Step 6 for one range: positions and attributes, chunk by chunk of the
// range's surfel index, in parallel within a chunk. `cover` is the range's
// soup's (world space for the world soup, prototype space for instances).
void emit_range(const Scene& scene, const TriangleRange& range, const std::vector<TrianglePlan>& plan, uint64_t total,
                const CoincidentCover& cover, const CrossRangeCover& across, size_t range_index,
                const SurfelOptions& options, const SurfelChunkSink& sink, ProgressMeter& meter,
                std::vector<Surfel>& chunk) {
  for (uint64_t g0 = 0; g0 < total; g0 += kChunk) {
    const uint64_t g1 = std::min(total, g0 + kChunk);
    chunk.resize(g1 - g0);
    tbb::parallel_for(tbb::blocked_range<uint64_t>(g0, g1, 1024), [&](const auto& r) {
      // The triangle holding surfel r.begin(): the last with first <= it.
      size_t i = size_t(std::upper_bound(plan.begin(), plan.end(), r.begin(),
                                         [](uint64_t g, const TrianglePlan& p) { return g < p.first; }) -
                        plan.begin()) - 1;
      for (uint64_t g = r.begin(); g != r.end(); ++g) {
        const auto span_of = [&](size_t k) {
          return uint64_t(plan[k].count) * (range.double_sided(uint32_t(k)) ? 2 : 1);
        };
        while (g >= plan[i].first + span_of(i)) ++i;
        const TrianglePlan& p = plan[i];
        const uint32_t id = range.first_id + uint32_t(i);  // scene triangle id
        const bool twin = range.double_sided(uint32_t(i));
        const uint64_t local = g - p.first;
        const uint32_t k = static_cast<uint32_t>(twin ? local / 2 : local);
        const TriangleRef tri = range.triangle(uint32_t(i));
        const V3f p0 = tri.position(0), p1 = tri.position(1), p2 = tri.position(2);
        const V3f n = (p1 - p0).cross(p2 - p0).normalized();
        Rng rng(hash_ids(options.seed, kPlaceDomain, id));
        const Imath::V2f shift(rng.uniform(), rng.uniform());
        const Imath::V2f b = square_to_triangle(r2_sample(k, shift));
        Surfel& s = chunk[g - g0];
        s.position = (1.f - b.x - b.y) * p0 + b.x * p1 + b.y * p2;
        s.normal = twin && (local & 1) ? -n : n;
        float share = p.share;
        uint32_t copies = 1;
        if (cover.any()) {
          const V3f at = range.instance ? range.soup_point(uint32_t(i), b.x, b.y) : s.position;
          copies = cover.cover(uint32_t(i), at);
        }
        if (across.any()) copies = std::max(copies, across.cover(range_index, uint32_t(i), s.position));
        share /= float(copies);
        // Cut-out or partly transparent surface (surface_opacity.h): the
        // surfel covers only what is there (0: dropped below).
        share *= surface_coverage(scene, id, b.x, b.y);
        s.radius = std::sqrt(share * kInvPi);
        if (!(s.radius > 0.f)) continue;
        const SurfaceColors colors = surface_colors(scene, id, b.x, b.y, 2.f * s.radius);
        set_surfel_material(scene, id, colors, options.glossy_roughness, s);
        s.radiance = colors.emission;
      }
      meter.advance(r.size());
    });
    std::erase_if(chunk, [](const Surfel& s) { return !(s.radius > 0.f); });
    sink(chunk);
  }
}

}  // namespace

SceneArea scene_area(const Scene& scene) {
  // The world soup in triangle order, then the instances (each summed on
  // its own, in parallel, then added in order: deterministic).
  const RangeArea world = range_area(triangle_range(scene, 0));
  std::vector<RangeArea> inst(scene.instances.size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, inst.size(), 1), [&](const auto& r) {
    for (size_t k = r.begin(); k != r.end(); ++k) inst[k] = range_area(triangle_range(scene, k + 1));
  });
  SceneArea out{world.total, world.skipped};
  for (const RangeArea& a : inst) {
    out.total += a.total;
    out.skipped += a.skipped;
  }
  return out;
}

float absolute_spacing(const Scene& scene, const SurfelOptions& options, double total_area) {
  const double s2 = options.spacing > 0.f ? static_cast<double>(options.spacing) * options.spacing
                                          : total_area / static_cast<double>(options.target_surfels);
  const double expected = total_area / s2;
  // The tree indexes surfels with 31 bits (tree_builder.h); refuse early,
  // before sampling, rather than after shading.
  if (expected > static_cast<double>(1ull << 31)) {
    throw InvalidArgument(fmt::format(
        "{}: surfels.spacing = {} would produce {:.3g} surfels for {:.6g} square units (limit 2^31)",
        scene.source_path, options.spacing, expected, total_area));
  }
  return static_cast<float>(std::sqrt(s2));
}

void sample_uniform(const Scene& scene, const SurfelOptions& options, const SurfelChunkSink& sink,
                    const ProgressFn& progress) {
  // 1-2. Total area (both faces of double-sided meshes) and the spacing:
  //      given, or the one that yields about target_surfels.
  const SceneArea area = scene_area(scene);
  if (area.skipped > 0) {
    spdlog::warn("{}: skipped {} of {} triangles with zero or non-finite area", scene.source_path,
                 area.skipped, scene.triangle_count());
  }
  if (!(area.total > 0.0)) return;
  const double spacing = absolute_spacing(scene, options, area.total);
  const double s2 = spacing * spacing;

  // 5. Coincident coplanar triangles, per soup (see the top of this file).
  const float tolerance = kCoplanarTolerance * float(spacing);
  // Plane offsets are measured from the bulk's centre: a far outlier's
  // would leave the rest of the scene's offsets with its float steps.
  const Box3f bounds = scene_bulk(scene).bounds;
  const CoincidentCover world_cover =
      soup_cover(scene.triangles, bounds.isEmpty() ? V3f(0.f) : bounds.center(), tolerance);
  const std::vector<CoincidentCover> covers = prototype_covers(scene, tolerance);
  const CrossRangeCover across(scene, bounds.isEmpty() ? V3f(0.f) : bounds.center(), tolerance);

  // 3-4, 6. Range by range: plan, then surfels. Ranges are planned a group
  //         at a time in parallel (a plan's shares are serial, and an
  //         instance is often too small to keep the cores busy alone), a
  //         group holding at most kGroupTriangles plan entries (besides
  //         one range larger than that on its own); their surfels then go
  //         out in range order. The meter counts the expected surfels (the
  //         exact count is known range by range).
  constexpr size_t kGroupTriangles = size_t(1) << 20;  // 24 MiB of plans
  ProgressMeter meter(progress, "sample_surfels", uint64_t(std::ceil(area.total / s2)));
  std::vector<Surfel> chunk;
  const size_t ranges = range_count(scene);
  for (size_t r0 = 0; r0 < ranges;) {
    size_t r1 = r0 + 1, planned = triangle_range(scene, r0).size();
    while (r1 < ranges && planned + triangle_range(scene, r1).size() <= kGroupTriangles)
      planned += triangle_range(scene, r1++).size();
    std::vector<std::vector<TrianglePlan>> plans(r1 - r0);
    std::vector<uint64_t> totals(r1 - r0);
    tbb::parallel_for(size_t(r0), r1, [&](size_t r) {
      totals[r - r0] = plan_range(triangle_range(scene, r), s2, options.seed, plans[r - r0]);
    });
    for (size_t r = r0; r < r1; ++r) {
      const TriangleRange range = triangle_range(scene, r);
      const CoincidentCover& cover = r == 0 ? world_cover : covers[range.instance->prototype];
      emit_range(scene, range, plans[r - r0], totals[r - r0], cover, across, r, options, sink, meter, chunk);
    }
    r0 = r1;
  }
  meter.finish();
}

}  // namespace pbgi
