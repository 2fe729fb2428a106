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
// Streaming: the per-triangle plan (counts, shares, offsets) is computed
// first; surfels are then produced chunk by chunk of the global surfel
// index, each surfel from its triangle's plan alone, so a chunk boundary
// may fall inside a triangle and no chunk depends on another.
//
// Albedo and emission come from the triangle's material; a textured or
// vertex-coloured one is evaluated at each surfel's point
// (server/scene/surface_colors.h), with textures averaged over a square of
// the surfel's area, so that the surfels of a mesh keep the texture's mean.
#include "server/scene/rng.h"
#include "server/scene/sample_patterns.h"
#include "server/scene/scene_validation.h"
#include "server/scene/surface_colors.h"
#include "server/surfels/coincident_surfaces.h"
#include "server/surfels/progress_meter.h"
#include "server/surfels/surfel_material.h"
#include "server/surfels/surfel_samplers.h"
#include "storage/format/errors.h"

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

struct TrianglePlan {
  float area = 0.f;       // one face; 0 = skipped
  uint32_t count = 0;     // samples (twins not counted)
  float share = 0.f;      // area each of its surfels stands for
  uint64_t first = 0;     // index of its first surfel
};

bool is_double_sided(const Scene& scene, uint32_t tri) { return scene.triangle(tri).double_sided(); }

// World-space area of one face of a scene triangle (instances transformed).
float triangle_area(const Scene& scene, uint32_t tri) {
  const TriangleRef r = scene.triangle(tri);
  const V3f p0 = r.position(0), p1 = r.position(1), p2 = r.position(2);
  return 0.5f * (p1 - p0).cross(p2 - p0).length();
}

}  // namespace

SceneArea scene_area(const Scene& scene) {
  SceneArea out;
  const uint64_t tris = scene.triangle_count();
  for (uint64_t i = 0; i < tris; ++i) {
    const float a = triangle_area(scene, uint32_t(i));
    if (!(std::isfinite(a) && a > 0.f)) {
      ++out.skipped;
      continue;
    }
    out.total += a * (is_double_sided(scene, static_cast<uint32_t>(i)) ? 2.0 : 1.0);
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
  // Scene triangle ids (Scene::triangle): instances are sampled as their
  // own surfaces, their prototype's triangles transformed on the fly.
  const size_t tris = size_t(scene.triangle_count());
  std::vector<TrianglePlan> plan(tris);

  // 1. Areas, in parallel; degenerate and non-finite triangles get area 0.
  tbb::parallel_for(tbb::blocked_range<size_t>(0, tris, 4096), [&](const auto& r) {
    for (size_t i = r.begin(); i != r.end(); ++i) {
      const float a = triangle_area(scene, uint32_t(i));
      plan[i].area = std::isfinite(a) && a > 0.f ? a : 0.f;
    }
  });
  double total_area = 0.0;  // both faces of double-sided meshes
  uint64_t skipped = 0;
  for (size_t i = 0; i < tris; ++i) {
    if (plan[i].area == 0.f) ++skipped;
    total_area += plan[i].area * (is_double_sided(scene, static_cast<uint32_t>(i)) ? 2.0 : 1.0);
  }
  if (!(total_area > 0.0)) return;

  // 2. Spacing: given, or the one that yields about target_surfels.
  const double spacing = absolute_spacing(scene, options, total_area);
  const double s2 = spacing * spacing;

  // 3. Sample counts per triangle, each from its own generator.
  tbb::parallel_for(tbb::blocked_range<size_t>(0, tris, 4096), [&](const auto& r) {
    for (size_t i = r.begin(); i != r.end(); ++i) {
      Rng rng(hash_ids(options.seed, kCountDomain, i));
      plan[i].count = static_cast<uint32_t>(std::floor(plan[i].area / s2 + rng.uniform()));
    }
  });

  // 4. Area shares, serially per mesh (see the top of this file), then the
  // output layout.
  const size_t meshes = std::max<size_t>(scene.mesh_count(), 1);
  std::vector<double> pending(meshes, 0.0);
  std::vector<int64_t> last(meshes, -1), largest(meshes, -1);
  auto mesh_of = [&](size_t i) -> size_t { return scene.mesh_ordinal(uint32_t(i)); };
  for (size_t i = 0; i < tris; ++i) {
    const size_t m = mesh_of(i);
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
    total += static_cast<uint64_t>(plan[i].count) * (is_double_sided(scene, i) ? 2 : 1);
  }
  if (skipped > 0) {
    spdlog::warn("{}: skipped {} of {} triangles with zero or non-finite area", scene.source_path,
                 skipped, tris);
  }

  // 5. Coincident coplanar triangles (see the top of this file).
  constexpr float kCoplanarTolerance = 0.01f;  // of the spacing
  // Every triangle with area covers points, also those that draw no
  // surfel; degenerate ones are left out.
  auto piece = [&](uint32_t i, PlanarPiece* out) {
    if (!(plan[i].area > 0.f)) return false;
    const TriangleRef r = scene.triangle(i);
    return PlanarPiece::of_triangle(r.position(0), r.position(1), r.position(2), out);
  };
  const Box3f bounds = scene.bounds();
  const CoincidentCover cover(uint32_t(tris), piece, bounds.isEmpty() ? V3f(0.f) : bounds.center(),
                              kCoplanarTolerance * float(spacing));

  // 6. Positions and attributes, chunk by chunk of the global surfel
  //    index, in parallel within a chunk.
  ProgressMeter meter(progress, "sample_surfels", total);
  std::vector<Surfel> chunk;
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
          return uint64_t(plan[k].count) * (is_double_sided(scene, uint32_t(k)) ? 2 : 1);
        };
        while (g >= plan[i].first + span_of(i)) ++i;
        const TrianglePlan& p = plan[i];
        const bool twin = is_double_sided(scene, static_cast<uint32_t>(i));
        const uint64_t local = g - p.first;
        const uint32_t k = static_cast<uint32_t>(twin ? local / 2 : local);
        const TriangleRef r = scene.triangle(uint32_t(i));
        const V3f p0 = r.position(0), p1 = r.position(1), p2 = r.position(2);
        const V3f n = (p1 - p0).cross(p2 - p0).normalized();
        Rng rng(hash_ids(options.seed, kPlaceDomain, i));
        const Imath::V2f shift(rng.uniform(), rng.uniform());
        const Imath::V2f b = square_to_triangle(r2_sample(k, shift));
        Surfel& s = chunk[g - g0];
        s.position = (1.f - b.x - b.y) * p0 + b.x * p1 + b.y * p2;
        s.normal = twin && (local & 1) ? -n : n;
        const float share = cover.any() ? p.share / float(cover.cover(uint32_t(i), s.position)) : p.share;
        s.radius = std::sqrt(share * kInvPi);
        const SurfaceColors colors = surface_colors(scene, static_cast<uint32_t>(i), b.x, b.y, 2.f * s.radius);
        set_surfel_material(scene, static_cast<uint32_t>(i), colors, options.glossy_roughness, s);
        s.radiance = colors.emission;
      }
      meter.advance(r.size());
    });
    sink(chunk);
  }
  meter.finish();
}

}  // namespace pbgi
