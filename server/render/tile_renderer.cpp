#include "server/render/tile_renderer.h"

#include "common/errors.h"
#include "server/render/batch_gather.h"
#include "server/render/interpolated_tile.h"
#include "server/scene/camera_rays.h"
#include "server/scene/rng.h"

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

// One camera sample: primary hit, direct light with shadow rays, indirect
// light from the gather.
PixelValue shade_sample(const RayScene& rays, Gatherer& gatherer, const Ray& ray,
                        const RenderOptions& options, uint64_t light_seed) {
  const SurfaceSample s = trace_sample(rays, ray, options.light_samples, light_seed, options.dome_visible);
  if (!s.gathers) return s.value;
  return finish_sample(s, gatherer.gather(s.receiver));
}

Ray sample_ray(const Camera& camera, uint32_t image_width, uint32_t image_height, uint32_t x,
               uint32_t y, uint32_t k, const RenderOptions& options, Rng& rng) {
  const Imath::V2f j = pixel_sample_offset(k, options.pixel_samples, rng);
  return camera_ray(camera, image_width, image_height, static_cast<float>(x) + j.x,
                    static_cast<float>(y) + j.y);
}

void store_rgb(std::vector<float>& layer, size_t pixel, const C3f& c) {
  layer[3 * pixel + 0] = c.x;
  layer[3 * pixel + 1] = c.y;
  layer[3 * pixel + 2] = c.z;
}

}  // namespace

void TileAovs::resize(const TileRect& r) {
  rect = r;
  const size_t pixels = static_cast<size_t>(r.width()) * r.height();
  beauty.assign(3 * pixels, 0.f);
  direct.assign(3 * pixels, 0.f);
  indirect.assign(3 * pixels, 0.f);
  albedo.assign(3 * pixels, 0.f);
  ao.assign(pixels, 0.f);
}

void TileAovs::store(size_t i, const PixelValue& sum, float scale) {
  store_rgb(beauty, i, sum.beauty * scale);
  store_rgb(direct, i, sum.direct * scale);
  store_rgb(indirect, i, sum.indirect * scale);
  store_rgb(albedo, i, sum.albedo * scale);
  ao[i] = sum.ao * scale;
}

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
  out.resize(rect);
  const size_t pixels = static_cast<size_t>(rect.width()) * rect.height();
  out.camera_samples = pixels * options.pixel_samples;

  GatherCounters total;
  // The gatherers of this tile share their traversal data (page views).
  const BatchGatherInput gather{tree, options.gather, std::make_shared<GatherCache>(), fog, &rays, [&] {
                                  if (is_cancelled()) throw cancel_error();
                                }};
  if (options.interpolation.mode == InterpolationMode::kAuto) {
    render_tile_interpolated(rays, camera, image_width, image_height, rect, options, gather, out, total);
    if (counters) counters->add(total);
    return out;
  }

  const float inv_spp = 1.f / static_cast<float>(options.pixel_samples);
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
            samples[i * spp + k] = trace_sample(rays, ray, options.light_samples,
                                                hash_ids(options.seed, kLightDomain, pixel_id, k),
                                                options.dome_visible);
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
    gather_receivers(gather, receivers, results, total);
    // 2c. Pixels.
    std::vector<GatherResult> by_sample(samples.size());
    for (size_t r = 0; r < receivers.size(); ++r) by_sample[owner[r]] = results[r];
    for (size_t i = 0; i < pixels; ++i) {
      PixelValue sum;
      for (uint32_t k = 0; k < spp; ++k) sum.add(finish_sample(samples[i * spp + k], by_sample[i * spp + k]));
      out.store(i, sum, inv_spp);
    }
    if (counters) counters->add(total);
    return out;
  }

  // 2. Rows in parallel; one Gatherer per task, reused for its pixels. The
  // random streams depend on the absolute pixel, so a tile renders the same
  // pixels identically however the image is split into tiles.
  std::mutex counters_mutex;
  tbb::parallel_for(tbb::blocked_range<uint32_t>(rect.y0, rect.y1, 1), [&](const auto& rows) {
    Gatherer gatherer(tree, options.gather, gather.cache);
    gatherer.set_volume_points(fog);
    gatherer.set_ray_scene(&rays);
    for (uint32_t y = rows.begin(); y != rows.end(); ++y) {
      if (is_cancelled()) throw cancel_error();
      for (uint32_t x = rect.x0; x < rect.x1; ++x) {
        const uint64_t pixel_id = static_cast<uint64_t>(y) * image_width + x;
        Rng rng(hash_ids(options.seed, kPixelDomain, pixel_id));
        PixelValue sum;
        for (uint32_t k = 0; k < options.pixel_samples; ++k) {
          const Ray ray = sample_ray(camera, image_width, image_height, x, y, k, options, rng);
          sum.add(shade_sample(rays, gatherer, ray, options, hash_ids(options.seed, kLightDomain, pixel_id, k)));
        }
        out.store(static_cast<size_t>(y - rect.y0) * rect.width() + (x - rect.x0), sum, inv_spp);
      }
    }
    std::lock_guard<std::mutex> lock(counters_mutex);
    total.add(gatherer.counters());
  });
  if (counters) counters->add(total);
  return out;
}

}  // namespace pbgi
