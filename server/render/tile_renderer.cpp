#include "server/render/tile_renderer.h"

#include "server/scene/camera_rays.h"
#include "server/scene/direct_lighting.h"
#include "server/scene/light_sampling.h"
#include "server/scene/rng.h"
#include "server/scene/sample_patterns.h"
#include "server/scene/surface_colors.h"
#include "storage/format/errors.h"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <mutex>

namespace pbgi {
namespace {

constexpr uint64_t kPixelDomain = 0x706978656cull;  // "pixel"
constexpr uint64_t kLightDomain = 0x6c69676874ull;  // "light"

struct PixelValue {
  C3f beauty{0, 0, 0}, direct{0, 0, 0}, indirect{0, 0, 0}, albedo{0, 0, 0};
  float ao = 0.f;
};

// Nearest light along the ray before tmax, if any.
bool nearest_light(const std::vector<Light>& lights, const Ray& ray, float tmax, C3f* radiance) {
  bool found = false;
  for (const Light& light : lights) {
    C3f l;
    float t, pdf;
    if (intersect_light(light, ray.origin, ray.direction, tmax, &l, &t, &pdf)) {
      tmax = t;
      *radiance = l;
      found = true;
    }
  }
  return found;
}

// One camera sample: primary hit, direct light with shadow rays, indirect
// light from the gather.
PixelValue shade_sample(const RayScene& rays, Gatherer& gatherer, const Ray& ray,
                        const RenderOptions& options, uint64_t light_seed) {
  PixelValue v;
  const Scene& scene = rays.scene();
  const Hit hit = rays.intersect(ray.origin, ray.direction, ray.tmin, ray.tmax);  // clipping range

  // 1. An emitter in front of the first surface: its radiance, nothing to gather.
  C3f emitted;
  if (nearest_light(scene.lights, ray, hit.t, &emitted)) {
    v.beauty = v.direct = emitted;
    v.ao = 1.f;
    return v;
  }
  // 2. Miss: black, fully accessible.
  if (!hit.valid()) {
    v.ao = 1.f;
    return v;
  }
  // 3. Surface: the receiver faces the camera (surfaces seen from behind
  // are lit on the side the camera sees); the shading normal is flipped with
  // it and falls back to the geometric one if it points below the surface.
  const TriangleSoup& t = scene.triangles;
  const uint32_t* idx = &t.indices[3 * hit.triangle];
  const V3f p = (1.f - hit.u - hit.v) * t.positions[idx[0]] + hit.u * t.positions[idx[1]] +
                hit.v * t.positions[idx[2]];
  V3f ng = hit.geometric_normal;
  V3f ns = rays.shading_normal(hit);
  if (ng.dot(-ray.direction) < 0.f) {
    ng = -ng;
    ns = -ns;
  }
  if (ns.dot(ng) <= 0.f) ns = ng;
  const SurfaceColors mat = surface_colors(scene, hit.triangle, hit.u, hit.v);  // textures applied
  const C3f brdf = mat.albedo * kInvPi;

  const C3f e_direct = direct_irradiance(rays, p, ns, options.light_samples, light_seed);
  const GatherResult g = gatherer.gather({p + rays.ray_epsilon() * ng, ns});
  v.albedo = mat.albedo;
  v.direct = brdf * e_direct + mat.emission;
  v.indirect = brdf * g.irradiance;
  v.ao = g.ao;
  v.beauty = v.direct + v.indirect;
  return v;
}

void store_rgb(std::vector<float>& layer, size_t pixel, const C3f& c) {
  layer[3 * pixel + 0] = c.x;
  layer[3 * pixel + 1] = c.y;
  layer[3 * pixel + 2] = c.z;
}

}  // namespace

TileAovs render_tile(const RayScene& rays, const tree::TreeSource& tree, const Camera& camera,
                     uint32_t image_width, uint32_t image_height, const TileRect& rect,
                     const RenderOptions& options, GatherCounters* counters,
                     const std::function<bool()>& cancelled) {
  // 1. Validate the request.
  options.validate();
  if (rect.x1 <= rect.x0 || rect.y1 <= rect.y0 || rect.x1 > image_width ||
      rect.y1 > image_height) {
    throw InvalidArgument(fmt::format(
        "tile [{}, {}) x [{}, {}) is empty or outside the {}x{} image of camera {}", rect.x0,
        rect.x1, rect.y0, rect.y1, image_width, image_height, camera.prim_path));
  }
  // The caller's predicate may not be thread-safe; calls are serialized.
  std::mutex cancel_mutex;
  auto is_cancelled = [&] {
    if (!cancelled) return false;
    std::lock_guard<std::mutex> lock(cancel_mutex);
    return cancelled();
  };
  auto cancel_error = [&] {
    return Cancelled(fmt::format("tile [{}, {}) x [{}, {}) of camera {} cancelled", rect.x0,
                                 rect.x1, rect.y0, rect.y1, camera.prim_path));
  };
  if (is_cancelled()) throw cancel_error();

  TileAovs out;
  out.rect = rect;
  const size_t pixels = static_cast<size_t>(rect.width()) * rect.height();
  out.beauty.assign(3 * pixels, 0.f);
  out.direct.assign(3 * pixels, 0.f);
  out.indirect.assign(3 * pixels, 0.f);
  out.albedo.assign(3 * pixels, 0.f);
  out.ao.assign(pixels, 0.f);

  // 2. Rows in parallel; one Gatherer per task, reused for its pixels. The
  // random streams depend on the absolute pixel, so a tile renders the same
  // pixels identically however the image is split into tiles.
  std::mutex counters_mutex;
  GatherCounters total;
  const float inv_spp = 1.f / static_cast<float>(options.pixel_samples);
  tbb::parallel_for(tbb::blocked_range<uint32_t>(rect.y0, rect.y1, 1), [&](const auto& rows) {
    Gatherer gatherer(tree, options.gather);
    for (uint32_t y = rows.begin(); y != rows.end(); ++y) {
      if (is_cancelled()) throw cancel_error();
      for (uint32_t x = rect.x0; x < rect.x1; ++x) {
        const uint64_t pixel_id = static_cast<uint64_t>(y) * image_width + x;
        Rng rng(hash_ids(options.seed, kPixelDomain, pixel_id));
        PixelValue sum;
        for (uint32_t k = 0; k < options.pixel_samples; ++k) {
          // One sample goes through the pixel's center (a crisp, repeatable
          // image); more are stratified over the pixel for antialiasing.
          const Imath::V2f j = options.pixel_samples == 1
                                   ? Imath::V2f(0.5f, 0.5f)
                                   : stratified_sample(k, options.pixel_samples, rng);
          const Ray ray = camera_ray(camera, image_width, image_height,
                                     static_cast<float>(x) + j.x, static_cast<float>(y) + j.y);
          const PixelValue v = shade_sample(rays, gatherer, ray, options,
                                            hash_ids(options.seed, kLightDomain, pixel_id, k));
          sum.beauty += v.beauty;
          sum.direct += v.direct;
          sum.indirect += v.indirect;
          sum.albedo += v.albedo;
          sum.ao += v.ao;
        }
        const size_t i = static_cast<size_t>(y - rect.y0) * rect.width() + (x - rect.x0);
        store_rgb(out.beauty, i, sum.beauty * inv_spp);
        store_rgb(out.direct, i, sum.direct * inv_spp);
        store_rgb(out.indirect, i, sum.indirect * inv_spp);
        store_rgb(out.albedo, i, sum.albedo * inv_spp);
        out.ao[i] = sum.ao * inv_spp;
      }
    }
    std::lock_guard<std::mutex> lock(counters_mutex);
    total.add(gatherer.counters());
  });
  if (counters) counters->add(total);
  return out;
}

}  // namespace pbgi
