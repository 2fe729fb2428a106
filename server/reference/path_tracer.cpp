#include "server/reference/path_tracer.h"

#include "server/reference/emissive_triangles.h"

#include "server/scene/brdf.h"
#include "server/scene/camera_rays.h"
#include "server/scene/light_sampling.h"
#include "server/scene/rng.h"
#include "server/scene/sample_patterns.h"
#include "server/scene/surface_colors.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>

namespace pbgi {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
// The isotropic phase function, 1 / (4 pi): the fog points' (fog_points.h).
constexpr float kInvFourPi = 0.0795774715f;

// The radiance estimates of one camera sample, split as the AOVs are.
struct PathSample {
  C3f direct{0, 0, 0};
  C3f indirect{0, 0, 0};
  C3f indirect1{0, 0, 0};
  C3f albedo{0, 0, 0};
  float ao = 1.f;
};

// Per-pixel running sums, in double so that thousands of samples of very
// different magnitude add up without drift.
struct PixelSums {
  double direct[3] = {}, indirect[3] = {}, indirect1[3] = {}, albedo[3] = {};
  double ao = 0.0;
};

// A surface point on a path, with its normals facing the side the ray came
// from (two-sided surfaces).
struct Vertex {
  V3f p;
  V3f error;  // rounding-error bound of p (RayScene::hit_point)
  V3f ng;  // geometric normal, unit
  V3f ns;  // shading normal, unit, in ng's hemisphere
  const Material* material = nullptr;
  C3f albedo{0, 0, 0}, emission{0, 0, 0};  // of the material at p (textures applied)
};

float max_component(const C3f& c) { return std::max({c.x, c.y, c.z}); }
bool is_black(const C3f& c) { return !(c.x > 0.f || c.y > 0.f || c.z > 0.f); }
bool is_finite(const C3f& c) {
  return std::isfinite(c.x) && std::isfinite(c.y) && std::isfinite(c.z);
}

// Power heuristic with beta = 2 (Veach 1997, ch. 9), one sample per strategy.
float power_heuristic(float pdf_a, float pdf_b) {
  const float a = pdf_a * pdf_a, b = pdf_b * pdf_b;
  return a + b > 0.f ? a / (a + b) : 0.f;
}

class PathTracer {
 public:
  PathTracer(const RayScene& rays, const ReferenceOptions& options)
      : rays_(rays), scene_(rays.scene()), options_(options), emitters_(rays.scene()) {}

  // One camera sample; *ray_count is incremented per ray traced.
  PathSample trace(const Ray& camera_ray, Rng& rng, uint64_t* ray_count) const;

 private:
  // The camera sample as seen through clear air (everything from x1 on).
  PathSample trace_from_x1(const Ray& camera_ray, const Hit& hit, Rng& rng, uint64_t* ray_count) const;
  Vertex make_vertex(const Hit& hit, const V3f& ray_dir) const;
  // Light of the UsdLux lights scattered once by the fog along the ray
  // (origin, dir) over [tmin, tmax] toward the origin (see path_tracer.h).
  C3f in_scattered(const V3f& origin, const V3f& dir, float tmin, float tmax, Rng& rng,
                   uint64_t* ray_count) const;
  // Origin of a ray leaving v along w (w in ng's hemisphere): offset by the
  // bound on p's own rounding error, so it is tight at any distance from
  // the world origin.
  static V3f offset_origin(const Vertex& v, const V3f& w) {
    return RayScene::offset_ray_origin(SurfacePoint{v.p, v.error}, v.ng, w);
  }

  const RayScene& rays_;
  const Scene& scene_;
  const ReferenceOptions& options_;
  const EmissiveTriangles emitters_;
};

Vertex PathTracer::make_vertex(const Hit& hit, const V3f& ray_dir) const {
  Vertex v;
  const SurfacePoint sp = rays_.hit_point(hit);
  v.p = sp.p;
  v.error = sp.error;
  // Face the side the ray arrived from (the viewer at the first hit, the
  // previous vertex after that), flipping the shading normal with the
  // geometric one and falling back to the latter if it points below the
  // surface: exactly what the daemon's tile renderer does for receivers.
  v.ng = hit.geometric_normal;
  v.ns = rays_.shading_normal(hit);
  if (v.ng.dot(ray_dir) > 0.f) {
    v.ng = -v.ng;
    v.ns = -v.ns;
  }
  if (v.ns.dot(v.ng) <= 0.f) v.ns = v.ng;
  v.material = &scene_.materials[scene_.triangle(hit.triangle).material()];
  const SurfaceColors colors = surface_colors(scene_, hit.triangle, hit.u, hit.v);
  v.albedo = colors.albedo;
  v.emission = colors.emission;
  return v;
}

C3f PathTracer::in_scattered(const V3f& origin, const V3f& dir, float tmin, float tmax, Rng& rng,
                             uint64_t* ray_count) const {
  // Without scattering fog no number is drawn: such renders are the
  // same as before fog scattered.
  const ParticipatingMedium* medium = rays_.medium();
  if (!medium || is_black(medium->albedo()) || scene_.lights.empty()) return C3f(0.f);
  const float u_pick = rng.uniform(), u_distance = rng.uniform();
  const MediumScatter ms = medium->sample_scatter(origin, dir, tmin, tmax, u_pick, u_distance);
  if (!(ms.weight > 0.f)) return C3f(0.f);
  // Next-event estimation at the scattering point: one sample of every
  // light, through the fog and past the surfaces (a point in the medium
  // has no surface to offset from).
  const V3f p = origin + dir * ms.t;
  C3f sum(0.f);
  for (const Light& light : scene_.lights) {
    const float u1 = rng.uniform(), u2 = rng.uniform();
    const LightSample ls = sample_light(light, p, u1, u2);
    if (!(ls.pdf > 0.f) || is_black(ls.radiance)) continue;
    const float t_light = std::isinf(ls.distance) ? kInf : ls.distance * (1.f - 1e-4f);
    ++*ray_count;
    if (!(t_light > 0.f) || rays_.occluded(p, ls.direction, 0.f, t_light)) continue;
    sum += ls.radiance * (rays_.transmittance(p, ls.direction, 0.f, t_light) / ls.pdf);
  }
  return medium->albedo() * sum * (ms.weight * kInvFourPi);
}

PathSample PathTracer::trace(const Ray& camera_ray, Rng& rng, uint64_t* ray_count) const {
  const Hit hit = rays_.intersect(camera_ray.origin, camera_ray.direction, camera_ray.tmin, camera_ray.tmax);
  ++*ray_count;
  if (!options_.fog_on_camera_rays || !rays_.medium()) return trace_from_x1(camera_ray, hit, rng, ray_count);
  // Fog between the camera and x1 (ReferenceOptions::fog_on_camera_rays):
  // what lies behind it is attenuated, and the lights' light it scatters
  // toward the camera is added to "direct" (no surface scattered it).
  const float t_end = hit.valid() ? hit.t : camera_ray.tmax;
  const C3f scattered = in_scattered(camera_ray.origin, camera_ray.direction, camera_ray.tmin, t_end, rng, ray_count);
  const float tr = rays_.transmittance(camera_ray.origin, camera_ray.direction, camera_ray.tmin, t_end);
  PathSample out = trace_from_x1(camera_ray, hit, rng, ray_count);
  out.direct = out.direct * tr + scattered;
  out.indirect *= tr;
  out.indirect1 *= tr;
  return out;
}

PathSample PathTracer::trace_from_x1(const Ray& camera_ray, const Hit& hit, Rng& rng, uint64_t* ray_count) const {
  PathSample out;
  const std::vector<Light>& lights = scene_.lights;

  // 1. The camera ray (traced by trace()). A visible area light in front
  // of the first surface is what the pixel shows, as in the daemon's tile
  // renderer.
  if (options_.lights_visible_to_camera) {
    float tmax = hit.t;
    bool seen = false;
    for (const Light& light : lights) {
      C3f le;
      float t = 0.f, pdf = 0.f;
      if (intersect_light(light, camera_ray.origin, camera_ray.direction, tmax, &le, &t, &pdf)) {
        tmax = t;
        out.direct = le;
        seen = true;
      }
    }
    if (seen) return out;  // ao 1, albedo 0
  }
  if (!hit.valid()) return out;  // black, ao 1, albedo 0
  Vertex v = make_vertex(hit, camera_ray.direction);
  out.albedo = v.albedo;
  out.direct += v.emission;

  // 2. Ambient accessibility at x1, from its own cosine-distributed ray.
  {
    const float u1 = rng.uniform(), u2 = rng.uniform();
    const V3f d = cosine_hemisphere(v.ns, u1, u2);
    const float tmax = options_.ao_max_distance > 0.f ? options_.ao_max_distance : kInf;
    // A direction under the geometric surface is blocked by the surface
    // itself; fog lets through its transmittance (the expected accessibility).
    const V3f o = offset_origin(v, d);
    out.ao = d.dot(v.ng) > 0.f && !rays_.occluded(o, d, 0.f, tmax) ? rays_.transmittance(o, d, 0.f, tmax) : 0.f;
    ++*ray_count;
  }

  // 3. The path. `surfaces` is the number of surfaces the light left before
  // arriving at x1 (see the header): 0 = direct, 1 = indirect1, >= 1 indirect.
  auto add = [&out](uint32_t surfaces, const C3f& c) {
    if (surfaces == 0) {
      out.direct += c;
      return;
    }
    out.indirect += c;
    if (surfaces == 1) out.indirect1 += c;
  };
  C3f beta(1.f, 1.f, 1.f);  // throughput from the camera to x_k, without f(x_k)
  V3f wo = -camera_ray.direction.normalized();  // from x_k toward x_{k-1}
  for (uint32_t k = 1;; ++k) {
    const Brdf brdf(brdf_lobes(*v.material, v.albedo), v.ns);

    // 3a. Next-event estimation at x_k: one sample of every light; light
    // from a UsdLux light reflected at x_k, ..., x1 left k-1 surfaces.
    if (!brdf.is_black()) {
      for (const Light& light : lights) {
        const float u1 = rng.uniform(), u2 = rng.uniform();
        const LightSample ls = sample_light(light, v.p, u1, u2);
        if (!(ls.pdf > 0.f) || is_black(ls.radiance)) continue;
        const float cos_s = v.ns.dot(ls.direction);
        if (!(cos_s > 0.f) || !(v.ng.dot(ls.direction) > 0.f)) continue;
        const C3f f = brdf.eval(wo, ls.direction);
        if (is_black(f)) continue;
        const V3f origin = offset_origin(v, ls.direction);
        const float tmax = std::isinf(ls.distance)
                               ? kInf
                               : ls.distance * (1.f - 1e-4f) - 2.f * (origin - v.p).length();
        ++*ray_count;
        if (tmax <= 0.f || rays_.occluded(origin, ls.direction, 0.f, tmax)) continue;
        const float w = ls.delta ? 1.f : power_heuristic(ls.pdf, brdf.pdf(wo, ls.direction));
        const float tr = rays_.transmittance(origin, ls.direction, 0.f, tmax);  // fog
        add(k - 1, beta * f * ls.radiance * (tr * cos_s * w / ls.pdf));
      }
    }

    // 3a'. Next-event estimation of emissive triangles: one point on one
    // of them (emissive_triangles.h), MIS-weighted against BSDF sampling
    // (3b). Light leaving the triangle x_{k+1} left k surfaces by x1.
    const bool nee_triangles = options_.sample_emissive_triangles && !emitters_.empty();
    if (nee_triangles && !brdf.is_black()) {
      const float u0 = rng.uniform(), u1 = rng.uniform(), u2 = rng.uniform();
      const EmitterSample es = emitters_.sample(u0, u1, u2);
      const V3f to = es.point.p - v.p;
      const float dist2 = to.length2();
      const V3f w = to / std::sqrt(dist2);
      const float cos_s = v.ns.dot(w), cos_l = std::fabs(es.normal.dot(w));
      if (es.pdf_area > 0.f && dist2 > 0.f && cos_s > 0.f && v.ng.dot(w) > 0.f && cos_l > 0.f) {
        const C3f le = surface_colors(scene_, es.triangle, es.b1, es.b2).emission;
        if (!is_black(le)) {
          // Both ends offset off their surfaces; the ray stops just short
          // of the emitter's point.
          const V3f from = offset_origin(v, w);
          const V3f target = RayScene::offset_ray_origin(es.point, es.normal, -w);
          ++*ray_count;
          if (!rays_.occluded(from, target - from, 0.f, 1.f - 1e-4f)) {
            const float pdf_light = es.pdf_area * dist2 / cos_l;
            const float wgt = power_heuristic(pdf_light, brdf.pdf(wo, w));
            const float span = (target - from).length();
            const float tr = rays_.transmittance(from, (target - from) / span, 0.f, span);  // fog
            add(k, beta * brdf.eval(wo, w) * le * (tr * cos_s * wgt / pdf_light));
          }
        }
      }
    }

    // 3b. BSDF sampling (brdf.h): for a Lambert surface cosine-weighted,
    // so f cos / pdf = albedo.
    const float u1 = rng.uniform(), u2 = rng.uniform();
    const BrdfSample bs = brdf.sample(wo, u1, u2);
    const V3f d = bs.wi;
    const float pdf_bsdf = bs.pdf;
    if (!(pdf_bsdf > 0.f) || !(d.dot(v.ng) > 0.f)) break;
    beta *= bs.weight;
    if (is_black(beta)) break;
    const V3f origin = offset_origin(v, d);
    const Hit next = rays_.intersect(origin, d);
    ++*ray_count;

    // UsdLux lights along the BSDF-sampled ray, MIS-weighted against 3a,
    // seen through the fog in front of them.
    for (const Light& light : lights) {
      C3f le;
      float t = 0.f, pdf_light = 0.f;
      if (!intersect_light(light, origin, d, next.t, &le, &t, &pdf_light)) continue;
      if (!(pdf_light > 0.f)) continue;
      add(k - 1, beta * le * (rays_.transmittance(origin, d, 0.f, t) * power_heuristic(pdf_bsdf, pdf_light)));
    }
    // Fog along the segment to the next surface (or out of the scene):
    // single scattering of the lights' light, which left no surface after
    // x_k: like x_{k+1}'s emission, k surfaces by x1 (path_tracer.h).
    add(k, beta * in_scattered(origin, d, 0.f, next.valid() ? next.t : kInf, rng, ray_count));
    if (!next.valid()) break;
    // ... and its extinction of what lies behind.
    beta *= rays_.transmittance(origin, d, 0.f, next.t);
    v = make_vertex(next, d);
    wo = -d;
    // Emission of x_{k+1}: it left a surface, so one more than above.
    // MIS-weighted against 3a' when emissive triangles are sampled.
    if (!is_black(v.emission)) {
      float wgt = 1.f;
      if (nee_triangles) {
        const float pdf_area = emitters_.pdf_area(next.triangle);
        const float cos_l = std::fabs(next.geometric_normal.dot(d));
        if (pdf_area > 0.f && cos_l > 0.f)
          wgt = power_heuristic(pdf_bsdf, pdf_area * next.t * next.t / cos_l);
      }
      add(k, beta * v.emission * wgt);
    }

    // 3c. Continue to x_{k+1}?
    if (k + 1 > options_.max_depth) break;
    if (k >= options_.rr_start_depth) {
      const float q = std::min(1.f, max_component(beta));
      if (rng.uniform() >= q) break;
      beta /= q;
    }
  }
  return out;
}

}  // namespace

ReferenceImage render_reference(const RayScene& rays, const Camera& camera,
                                const ReferenceOptions& options,
                                const ReferenceProgressFn& progress, ReferenceStats* stats) {
  options.validate();
  const auto start = std::chrono::steady_clock::now();
  auto elapsed = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };

  const uint32_t W = options.width, H = options.height, T = options.tile_size;
  const uint32_t tiles_x = (W + T - 1) / T, tiles_y = (H + T - 1) / T;
  std::vector<PixelSums> sums(size_t(W) * H);
  const PathTracer tracer(rays, options);
  std::atomic<uint64_t> ray_count{0}, nonfinite{0};

  // 1. Passes of pass_spp samples; each pixel's samples are added in sample
  // order by the one task that owns its tile, so the sums do not depend on
  // scheduling.
  uint32_t done = 0;
  while (done < options.spp) {
    const uint32_t s0 = done, s1 = std::min(options.spp, done + options.pass_spp);
    tbb::parallel_for(
        tbb::blocked_range<uint32_t>(0, tiles_x * tiles_y),
        [&](const tbb::blocked_range<uint32_t>& range) {
          uint64_t local_rays = 0, local_nonfinite = 0;
          for (uint32_t tile = range.begin(); tile != range.end(); ++tile) {
            const uint32_t x0 = (tile % tiles_x) * T, y0 = (tile / tiles_x) * T;
            for (uint32_t y = y0; y < std::min(H, y0 + T); ++y) {
              for (uint32_t x = x0; x < std::min(W, x0 + T); ++x) {
                const uint64_t pixel = uint64_t(y) * W + x;
                const uint64_t pixel_seed = hash_ids(options.seed, pixel);
                // Per-pixel shift of the R2 sequence (Cranley-Patterson).
                Rng shift_rng(pixel_seed, ~0ull);
                const Imath::V2f shift(shift_rng.uniform(), shift_rng.uniform());
                PixelSums& acc = sums[pixel];
                for (uint32_t s = s0; s < s1; ++s) {
                  Rng rng(pixel_seed, s);
                  const Imath::V2f j = r2_sample(s, shift);
                  const Ray ray = camera_ray(camera, W, H, float(x) + j.x, float(y) + j.y);
                  const PathSample ps = tracer.trace(ray, rng, &local_rays);
                  if (!is_finite(ps.direct) || !is_finite(ps.indirect) ||
                      !is_finite(ps.indirect1)) {
                    ++local_nonfinite;
                    continue;
                  }
                  for (int c = 0; c < 3; ++c) {
                    acc.direct[c] += ps.direct[c];
                    acc.indirect[c] += ps.indirect[c];
                    acc.indirect1[c] += ps.indirect1[c];
                    acc.albedo[c] += ps.albedo[c];
                  }
                  acc.ao += ps.ao;
                }
              }
            }
          }
          ray_count += local_rays;
          nonfinite += local_nonfinite;
        },
        tbb::simple_partitioner());
    done = s1;
    if (progress && !progress({done, options.spp, elapsed()})) break;
  }

  // 2. Means.
  ReferenceImage image;
  image.width = W;
  image.height = H;
  image.spp = done;
  const size_t n = size_t(W) * H;
  image.beauty.resize(n * 3);
  image.direct.resize(n * 3);
  image.indirect.resize(n * 3);
  image.indirect1.resize(n * 3);
  image.albedo.resize(n * 3);
  image.ao.resize(n);
  const double inv = done > 0 ? 1.0 / done : 0.0;
  for (size_t i = 0; i < n; ++i) {
    const PixelSums& acc = sums[i];
    for (int c = 0; c < 3; ++c) {
      image.direct[3 * i + c] = float(acc.direct[c] * inv);
      image.indirect[3 * i + c] = float(acc.indirect[c] * inv);
      image.indirect1[3 * i + c] = float(acc.indirect1[c] * inv);
      image.albedo[3 * i + c] = float(acc.albedo[c] * inv);
      image.beauty[3 * i + c] = float((acc.direct[c] + acc.indirect[c]) * inv);
    }
    image.ao[i] = float(acc.ao * inv);
  }

  if (stats) {
    stats->camera_samples = uint64_t(done) * n;
    stats->rays = ray_count.load();
    stats->nonfinite_samples = nonfinite.load();
    stats->seconds = elapsed();
  }
  return image;
}

}  // namespace pbgi
