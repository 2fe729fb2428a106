// The entry points of surfel generation: pick the sampler, and either
// collect (sample_surfels) or stream batches through shading into a sink
// (generate_surfels).
#include "server/scene/scene_validation.h"
#include "server/surfels/surfel_samplers.h"
#include "server/surfels/surfels.h"

#include <chrono>

namespace pbgi {
namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

void run_sampler(const Scene& scene, const SurfelOptions& options, const SurfelChunkSink& sink,
                 const ProgressFn& progress) {
  options.validate();
  validate_scene(scene);
  if (options.sampler == SurfelSampler::kPoisson) {
    sample_poisson(scene, options, sink, progress);
  } else {
    sample_uniform(scene, options, sink, progress);
  }
}

}  // namespace

std::vector<Surfel> sample_surfels(const Scene& scene, const SurfelOptions& options, const ProgressFn& progress) {
  std::vector<Surfel> out;
  run_sampler(scene, options, [&](std::span<const Surfel> chunk) { out.insert(out.end(), chunk.begin(), chunk.end()); },
              progress);
  return out;
}

SurfelGenerationStats generate_surfels(const Scene& scene, const RayScene& rays, const SurfelOptions& options,
                                       const SurfelSink& sink, const ProgressFn& progress) {
  SurfelGenerationStats stats;
  std::vector<Surfel> batch;
  batch.reserve(options.batch_surfels);
  // Shades and hands on what the batch holds; the sampler's time is what
  // remains of the total.
  auto flush = [&] {
    if (batch.empty()) return;
    auto t0 = Clock::now();
    shade_direct(rays, options, std::span<Surfel>(batch), stats.surfels);
    stats.shade_seconds += seconds_since(t0);
    t0 = Clock::now();
    sink(batch);
    stats.sink_seconds += seconds_since(t0);
    stats.surfels += batch.size();
    ++stats.batches;
    batch.clear();
  };
  const auto t0 = Clock::now();
  run_sampler(scene, options,
              [&](std::span<const Surfel> chunk) {
                for (size_t at = 0; at < chunk.size();) {
                  const size_t n = std::min(chunk.size() - at, size_t(options.batch_surfels) - batch.size());
                  batch.insert(batch.end(), chunk.begin() + at, chunk.begin() + at + n);
                  at += n;
                  if (batch.size() == options.batch_surfels) flush();
                }
              },
              progress);
  flush();
  stats.sample_seconds = seconds_since(t0) - stats.shade_seconds - stats.sink_seconds;
  return stats;
}

}  // namespace pbgi
