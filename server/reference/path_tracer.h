// The reference renderer: an unbiased Monte Carlo path tracer over the same
// RayScene, lights and camera model as the daemon, producing the daemon's
// AOVs so that PBGI images can be measured against it ("speed against
// error").
//
// Light transport (surfaces reflect by the Material's BRDF, server/scene/
// brdf.h: Lambert, plus a GGX lobe for glossy and metallic materials; matte
// materials are exactly Lambert, f = albedo / pi):
//  * Surfaces are two-sided: at every path vertex the geometric normal is
//    flipped toward the incoming ray (at the first hit: toward the camera,
//    as the daemon's receivers are), the shading normal with it, and the
//    shading normal is replaced by the geometric one if it then points below
//    the surface (the daemon's rule). Material emission leaves both sides.
//  * Directions are sampled from the BRDF (Brdf::sample: cosine-weighted
//    around the shading normal for the diffuse lobe, GGX visible normals
//    for the specular one); a direction below the geometric surface ends
//    the path. The BRDF's pdf is the BSDF side of every MIS weight below.
//  * UsdLux lights are sampled at every vertex with sample_light (each light
//    once: next-event estimation); light hit by a BSDF-sampled ray
//    (intersect_light, up to the next surface) is counted too, and the two
//    are combined with the power heuristic (Veach 1997). Delta lights get
//    no BSDF-sampled term. Lights do not occlude surfaces or each other for
//    path and shadow rays; a camera ray stops at the nearest visible light.
//  * Emissive triangles are sampled at every vertex too (one point on one
//    triangle chosen in proportion to area x emission, emissive_triangles.h)
//    and combined with BSDF-sampled hits by the power heuristic, so small
//    emitters do not make fireflies (ReferenceOptions::
//    sample_emissive_triangles; off, they are found by BSDF sampling only,
//    with weight 1). Their emission leaves both sides; a camera ray that
//    hits one sees it with weight 1.
//  * Secondary rays start off the surface by the bound on the hit point's
//    own rounding error (RayScene::offset_ray_origin), so a scene far from
//    the world origin renders as it does near it.
//  * Fog (RayScene::medium(), server/volumes/fog_field.h) attenuates every
//    shadow ray, every path segment and the AO ray by its ray-marched
//    transmittance, and scatters the UsdLux lights' light once: along every
//    path segment leaving a surface x_k (to x_{k+1}, or out of the scene)
//    one distance t is drawn in proportion to sigma_t(t) T(x_k, t)
//    (ParticipatingMedium::sample_scatter: inverting the marched optical
//    depth) and every light is sampled from there (shadow ray, fog
//    transmittance), with the isotropic phase function 1/(4 pi) and the
//    fog's albedo -- what the daemon's fog points carry (fog_points.h).
//    The estimate is (1 - T(segment)) * albedo / (4 pi) * sum over lights of
//    Le T V / pdf, added besides the path's continuation to x_{k+1}.
//    Fog on the camera ray (between the camera and x1) only with
//    ReferenceOptions::fog_on_camera_rays: the daemon's tile renderer
//    shades x1 as seen through clear air, so by default the reference does
//    too and the AOVs compare; with it, x1's light is attenuated and the
//    light scattered toward the camera is added to "direct".
//    Not modelled, as in the daemon: multiple scattering (paths do not
//    continue from a point in the medium) and emissive triangles lighting
//    the fog.
//  * Russian roulette once a path has ReferenceOptions::rr_start_depth
//    reflections, with continuation probability min(1, max component of the
//    throughput); ReferenceOptions::max_depth caps the reflections.
//
// AOVs. x1 is the first surface the camera ray hits. The split follows the
// daemon's: "direct" is light arriving at x1 straight from UsdLux lights
// (what its shadow rays compute), "indirect" is light arriving at x1 from
// surfaces, emitted or reflected by them (what its surfel gather computes).
// Precisely, for light reaching the camera via x1, let s be the number of
// surfaces it left before arriving at x1: for a path light -> x_k -> ... ->
// x1, s = k - 1; for a path starting at an emissive triangle x_{k+1}, s = k.
//   direct    s = 0: UsdLux light reflected once at x1, plus x1's own
//             emission, plus (lights_visible_to_camera) the radiance of the
//             nearest area light in front of x1, which then hides x1: such a
//             pixel has albedo 0 and ao 1, as in the daemon.
//   indirect1 s = 1, the one-bounce interreflection:
//               integral over the hemisphere at x1 of
//               f(x1) [Le(x2 -> x1) + Ld(x2 -> x1)] cos(theta) d(omega),
//             where x2 is the surface seen from x1 in that direction, Le its
//             emission and Ld its direct lighting from UsdLux lights
//             (reflected by x2's BRDF toward x1: a glossy caustic is here).
//             This is what a single-bounce PBGI gather of surfels shaded
//             with emission + direct light estimates, with x1's diffuse
//             lobe times the irradiance plus its GGX lobe convolved by the
//             glossy gather (docs/glossy.md); a glossy x2 (sender) is a
//             surfel that keeps its GGX lobe lit by direct light, whose
//             wavelet-coded radiance the gather evaluates towards x1
//             (docs/gather.md, section 3).
//             Fog scattering counts as a surface here: light of a UsdLux
//             light scattered once in the fog on its way to x1 (what the
//             daemon's gather adds from its fog points) has s = 1.
//   indirect  s >= 1: all interreflections (includes indirect1).
//   beauty    direct + indirect.
//   albedo    albedo of x1's material (0 where the camera ray misses).
//   ao        accessibility of x1: the fraction of cosine-weighted hemisphere
//             directions around the shading normal whose ray hits no
//             surface within ao_max_distance (1 = open; 1 where the camera
//             ray misses). Lights are not occluders.
// Pixels where the camera ray misses everything show the scene's DomeLights
// (intersect_light reports a dome for escaping rays; counted in "direct"
// when lights_visible_to_camera), else black; paths that escape pick up
// the dome's radiance MIS-weighted against its importance-sampled NEE.
// Albedo and emission are evaluated with textures (surface_colors.h).
//
// Sampling and determinism: sample s of pixel (x, y) draws from its own
// PCG32 stream seeded by hash(seed, pixel index) with stream s; the pixel
// position is an R2 low-discrepancy point with a per-pixel random shift.
// Samples are accumulated per pixel in double precision in sample order, so
// the image is bit-identical for any thread count, tile size or pass split.
// Non-finite samples (numerical accidents) are dropped (they count as
// zero in the mean) and counted.
//
// Thread-safety: render_reference is reentrant; it runs TBB tasks in the
// caller's task arena (limit threads with tbb::task_arena). The RayScene is
// only read.
#pragma once

#include "server/reference/reference_options.h"
#include "server/scene/ray_scene.h"

#include <cstdint>
#include <functional>
#include <vector>

namespace pbgi {

// Row-major, y down from the top, pixel-interleaved: rgb AOVs hold 3 floats
// per pixel, ao 1. Values are per-pixel means over `spp` samples.
struct ReferenceImage {
  uint32_t width = 0, height = 0;
  uint32_t spp = 0;  // samples per pixel actually taken (< options.spp if stopped early)
  std::vector<float> beauty, direct, indirect, indirect1, albedo, ao;
};

struct ReferenceStats {
  uint64_t camera_samples = 0;
  uint64_t rays = 0;              // closest-hit and shadow rays traced
  uint64_t nonfinite_samples = 0; // dropped samples (see above)
  double seconds = 0.0;           // wall time of render_reference
};

struct ReferenceProgress {
  uint32_t spp_done = 0;
  uint32_t spp_total = 0;
  double seconds = 0.0;  // since the render started
};

// Called after each pass with the samples so far; return false to stop (the
// returned image then holds the passes done). Runs on the calling thread.
using ReferenceProgressFn = std::function<bool(const ReferenceProgress&)>;

// Renders `camera` of rays.scene(). Throws InvalidArgument for bad options.
ReferenceImage render_reference(const RayScene& rays, const Camera& camera,
                                const ReferenceOptions& options,
                                const ReferenceProgressFn& progress = {},
                                ReferenceStats* stats = nullptr);

}  // namespace pbgi
