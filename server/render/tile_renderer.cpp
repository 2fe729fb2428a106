#include "server/render/tile_renderer.h"

#include "server/scene/brdf.h"
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

#include <algorithm>
#include <memory>
#include <mutex>
#include <span>
#include <vector>

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

// One camera sample up to the gather: primary hit and direct light with
// shadow rays; `receiver` is set when the sample needs indirect light, to
// be finished by finish_sample() with the gather's result.
struct SurfaceSample {
  PixelValue value;
  bool gathers = false;
  Receiver receiver;         // glossy lobe set for materials with a specular lobe
  C3f brdf{0, 0, 0};         // Lambert albedo / pi (direct light)
  C3f indirect_brdf{0, 0, 0};  // the diffuse lobe / pi (indirect light)
};

SurfaceSample trace_sample(const RayScene& rays, const Ray& ray, const RenderOptions& options,
                           uint64_t light_seed) {
  SurfaceSample out;
  PixelValue& v = out.value;
  const Scene& scene = rays.scene();
  // Only what lies within the camera's clipping range is seen (camera_ray
  // sets tmin/tmax from it): a near plane cuts through occluders in front.
  const Hit hit = rays.intersect(ray.origin, ray.direction, ray.tmin, ray.tmax);

  // 1. An emitter in front of the first surface: its radiance, nothing to gather.
  C3f emitted;
  if (nearest_light(scene.lights, ray, hit.valid() ? hit.t : ray.tmax, &emitted)) {
    v.beauty = v.direct = emitted;
    v.ao = 1.f;
    return out;
  }
  // 2. Miss: black, fully accessible.
  if (!hit.valid()) {
    v.ao = 1.f;
    return out;
  }
  // 3. Surface: the receiver faces the camera (surfaces seen from behind
  // are lit on the side the camera sees); the shading normal is flipped with
  // it and falls back to the geometric one if it points below the surface.
  const TriangleRef tri = scene.triangle(hit.triangle);
  const V3f p = (1.f - hit.u - hit.v) * tri.position(0) + hit.u * tri.position(1) + hit.v * tri.position(2);
  V3f ng = hit.geometric_normal;
  V3f ns = rays.shading_normal(hit);
  if (ng.dot(-ray.direction) < 0.f) {
    ng = -ng;
    ns = -ns;
  }
  if (ns.dot(ng) <= 0.f) ns = ng;
  const SurfaceColors mat = surface_colors(scene, hit.triangle, hit.u, hit.v);  // textures applied
  out.brdf = mat.albedo * kInvPi;
  // Indirect light is reflected by the material's BRDF (brdf.h), as in the
  // reference's "indirect" AOV (path_tracer.h): its diffuse lobe times the
  // gathered irradiance plus its GGX lobe, which the gather convolves
  // towards the camera (the receiver's glossy part, set below).
  const Material& material = scene.materials[tri.material()];
  const BrdfLobes lobes = brdf_lobes(material, mat.albedo);
  out.indirect_brdf = lobes.diffuse * kInvPi;

  v.albedo = mat.albedo;
  if (!lobes.specular) {
    const C3f e_direct = direct_irradiance(rays, p, ns, options.light_samples, light_seed);
    v.direct = out.brdf * e_direct + mat.emission;
  } else {
    // A GGX lobe reflects each light sample through the whole BRDF, as the
    // reference's direct AOV does (a metal's highlight, and no Lambertian
    // term it does not have): the same samples and shadow rays as
    // direct_irradiance(), each weighted by f(wo, wi).
    thread_local std::vector<IncidentSample> light;
    incident_light(rays, p, ns, options.light_samples, light_seed, light);
    const Brdf brdf(lobes, ns);
    const V3f wo = -ray.direction.normalized();
    C3f reflected(0, 0, 0);
    for (const IncidentSample& in : light) reflected += brdf.eval(wo, in.direction) * in.irradiance;
    v.direct = reflected + mat.emission;
  }
  out.gathers = true;
  // Off the surface by the hit point's own rounding bound (not a scene-wide
  // epsilon), so receivers far from the origin keep their precision.
  out.receiver = {RayScene::offset_ray_origin(rays.hit_point(hit), ng, ng), ns};
  if (lobes.specular) {
    out.receiver.glossy.view = -ray.direction.normalized();
    out.receiver.glossy.roughness = std::clamp(material.roughness, 0.f, 1.f);
    out.receiver.glossy.specular = lobes.f0;
  }
  return out;
}

// Adds the indirect light of the gather to a traced sample.
PixelValue finish_sample(const SurfaceSample& s, const GatherResult& g) {
  PixelValue v = s.value;
  if (!s.gathers) return v;
  v.indirect = s.indirect_brdf * g.irradiance + g.glossy;
  v.ao = g.ao;
  v.beauty = v.direct + v.indirect;
  return v;
}

// One camera sample: primary hit, direct light with shadow rays, indirect
// light from the gather.
PixelValue shade_sample(const RayScene& rays, Gatherer& gatherer, const Ray& ray,
                        const RenderOptions& options, uint64_t light_seed) {
  const SurfaceSample s = trace_sample(rays, ray, options, light_seed);
  if (!s.gathers) return s.value;
  return finish_sample(s, gatherer.gather(s.receiver));
}

// The camera ray of sample k of pixel (x, y): one sample goes through the
// pixel's center (a crisp, repeatable image); more are stratified over the
// pixel for antialiasing.
Ray sample_ray(const Camera& camera, uint32_t image_width, uint32_t image_height, uint32_t x,
               uint32_t y, uint32_t k, const RenderOptions& options, Rng& rng) {
  const Imath::V2f j = options.pixel_samples == 1 ? Imath::V2f(0.5f, 0.5f)
                                                  : stratified_sample(k, options.pixel_samples, rng);
  return camera_ray(camera, image_width, image_height, static_cast<float>(x) + j.x,
                    static_cast<float>(y) + j.y);
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
                     const std::function<bool()>& cancelled, std::shared_ptr<const VolumePoints> fog) {
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

  std::mutex counters_mutex;
  GatherCounters total;
  const float inv_spp = 1.f / static_cast<float>(options.pixel_samples);
  // The gatherers of this tile share their traversal data (page views).
  const auto cache = std::make_shared<GatherCache>();
  const auto store = [&](uint32_t x, uint32_t y, const PixelValue& sum) {
    const size_t i = static_cast<size_t>(y - rect.y0) * rect.width() + (x - rect.x0);
    store_rgb(out.beauty, i, sum.beauty * inv_spp);
    store_rgb(out.direct, i, sum.direct * inv_spp);
    store_rgb(out.indirect, i, sum.indirect * inv_spp);
    store_rgb(out.albedo, i, sum.albedo * inv_spp);
    out.ao[i] = sum.ao * inv_spp;
  };
  const auto accumulate = [](PixelValue& sum, const PixelValue& v) {
    sum.beauty += v.beauty;
    sum.direct += v.direct;
    sum.indirect += v.indirect;
    sum.albedo += v.albedo;
    sum.ao += v.ao;
  };

  if (options.gather.method == GatherMethod::kFpbgi) {
    // Factorized: the tile's receivers are gathered together, so that
    // nearby ones share their far light.
    // 2a. Primary hits and direct light, rows in parallel.
    const uint32_t spp = options.pixel_samples;
    std::vector<SurfaceSample> samples(pixels * spp);
    tbb::parallel_for(tbb::blocked_range<uint32_t>(rect.y0, rect.y1, 1), [&](const auto& rows) {
      for (uint32_t y = rows.begin(); y != rows.end(); ++y) {
        if (is_cancelled()) throw cancel_error();
        for (uint32_t x = rect.x0; x < rect.x1; ++x) {
          const uint64_t pixel_id = static_cast<uint64_t>(y) * image_width + x;
          Rng rng(hash_ids(options.seed, kPixelDomain, pixel_id));
          const size_t i = static_cast<size_t>(y - rect.y0) * rect.width() + (x - rect.x0);
          for (uint32_t k = 0; k < spp; ++k) {
            const Ray ray = sample_ray(camera, image_width, image_height, x, y, k, options, rng);
            samples[i * spp + k] =
                trace_sample(rays, ray, options, hash_ids(options.seed, kLightDomain, pixel_id, k));
          }
        }
      }
    });
    // 2b. Receivers in scan order, gathered in batches of about 1024 (a
    // 32 x 32 tile, the clustering's unit) in parallel.
    std::vector<Receiver> receivers;
    std::vector<uint32_t> owner;
    for (size_t i = 0; i < samples.size(); ++i) {
      if (!samples[i].gathers) continue;
      receivers.push_back(samples[i].receiver);
      owner.push_back(static_cast<uint32_t>(i));
    }
    std::vector<GatherResult> results(receivers.size());
    constexpr size_t kBatch = 1024;
    const size_t batches = (receivers.size() + kBatch - 1) / kBatch;
    tbb::parallel_for(tbb::blocked_range<size_t>(0, batches, 1), [&](const auto& range) {
      Gatherer gatherer(tree, options.gather, cache);
      gatherer.set_volume_points(fog);
      for (size_t b = range.begin(); b != range.end(); ++b) {
        if (is_cancelled()) throw cancel_error();
        const size_t begin = b * kBatch, end = std::min(receivers.size(), begin + kBatch);
        gatherer.gather_tile(std::span<const Receiver>(receivers.data() + begin, end - begin),
                             std::span<GatherResult>(results.data() + begin, end - begin));
      }
      std::lock_guard<std::mutex> lock(counters_mutex);
      total.add(gatherer.counters());
    });
    // 2c. Pixels.
    std::vector<GatherResult> by_sample(samples.size());
    for (size_t r = 0; r < receivers.size(); ++r) by_sample[owner[r]] = results[r];
    for (uint32_t y = rect.y0; y < rect.y1; ++y) {
      for (uint32_t x = rect.x0; x < rect.x1; ++x) {
        const size_t i = static_cast<size_t>(y - rect.y0) * rect.width() + (x - rect.x0);
        PixelValue sum;
        for (uint32_t k = 0; k < spp; ++k) {
          accumulate(sum, finish_sample(samples[i * spp + k], by_sample[i * spp + k]));
        }
        store(x, y, sum);
      }
    }
    if (counters) counters->add(total);
    return out;
  }

  // 2. Rows in parallel; one Gatherer per task, reused for its pixels. The
  // random streams depend on the absolute pixel, so a tile renders the same
  // pixels identically however the image is split into tiles.
  tbb::parallel_for(tbb::blocked_range<uint32_t>(rect.y0, rect.y1, 1), [&](const auto& rows) {
    Gatherer gatherer(tree, options.gather, cache);
      gatherer.set_volume_points(fog);
    for (uint32_t y = rows.begin(); y != rows.end(); ++y) {
      if (is_cancelled()) throw cancel_error();
      for (uint32_t x = rect.x0; x < rect.x1; ++x) {
        const uint64_t pixel_id = static_cast<uint64_t>(y) * image_width + x;
        Rng rng(hash_ids(options.seed, kPixelDomain, pixel_id));
        PixelValue sum;
        for (uint32_t k = 0; k < options.pixel_samples; ++k) {
          const Ray ray = sample_ray(camera, image_width, image_height, x, y, k, options, rng);
          accumulate(sum, shade_sample(rays, gatherer, ray, options,
                                       hash_ids(options.seed, kLightDomain, pixel_id, k)));
        }
        store(x, y, sum);
      }
    }
    std::lock_guard<std::mutex> lock(counters_mutex);
    total.add(gatherer.counters());
  });
  if (counters) counters->add(total);
  return out;
}

}  // namespace pbgi
