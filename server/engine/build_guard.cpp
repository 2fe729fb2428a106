#include "server/engine/build_guard.h"

#include "common/errors.h"
#include "server/surfels/surfel_samplers.h"

#include <fmt/format.h>

namespace pbgi {

BuildGuard::BuildGuard(std::string scene_path, uint64_t max_surfels, CancelledFn cancelled)
    : scene_path_(std::move(scene_path)), max_surfels_(max_surfels), cancelled_(std::move(cancelled)) {}

void BuildGuard::check_cancelled() const {
  if (cancelled_ && cancelled_()) {
    throw Cancelled(fmt::format("build of '{}' stopped: no client is waiting for it any more", scene_path_));
  }
}

void BuildGuard::check_target(const SurfelOptions& options, uint64_t max_surfels) {
  if (max_surfels > 0 && options.spacing == 0.f && !options.adaptive() && options.target_surfels > max_surfels) {
    throw ResourceExhausted(fmt::format("build.target_surfels = {} exceeds the daemon's limits.max_surfels = {}",
                                        options.target_surfels, max_surfels));
  }
}

void BuildGuard::check_expected(const Scene& scene, const SurfelOptions& options) const {
  check_target(options, max_surfels_);
  if (max_surfels_ == 0 || options.adaptive() || options.spacing == 0.f) return;
  const double area = scene_area(scene).total;
  const double expected = area / (double(options.spacing) * options.spacing);
  if (expected > double(max_surfels_)) {
    throw ResourceExhausted(fmt::format(
        "scene '{}': surfel spacing {:.6g} over {:.6g} square units gives about {:.0f} surfels, more than the "
        "daemon's limits.max_surfels = {}",
        scene_path_, options.spacing, area, expected, max_surfels_));
  }
}

void BuildGuard::count(uint64_t n) {
  surfels_ += n;
  if (max_surfels_ > 0 && surfels_ > max_surfels_ + max_surfels_ / 100) {
    throw ResourceExhausted(fmt::format("scene '{}': the build passed {} surfels, over the daemon's "
                                        "limits.max_surfels = {} (stopped)",
                                        scene_path_, surfels_, max_surfels_));
  }
  check_cancelled();
}

}  // namespace pbgi
