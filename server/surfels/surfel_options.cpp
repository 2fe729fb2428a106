#include "server/surfels/surfel_options.h"

#include "storage/format/errors.h"

#include <fmt/format.h>

#include <cmath>

namespace pbgi {

void SurfelOptions::validate() const {
  if (!std::isfinite(spacing) || spacing < 0.f) {
    throw InvalidArgument(fmt::format("surfels.spacing = {}: must be finite and >= 0", spacing));
  }
  // The tree refuses more than 2^31 surfels (storage/tree/tree_builder.h).
  if (spacing == 0.f && (target_surfels == 0 || target_surfels > (1ull << 31))) {
    throw InvalidArgument(fmt::format(
        "surfels.target_surfels = {}: must be in [1, 2^31] when spacing is 0", target_surfels));
  }
  if (light_samples == 0 || light_samples > 4096) {
    throw InvalidArgument(
        fmt::format("surfels.light_samples = {}: must be in [1, 4096]", light_samples));
  }
}

}  // namespace pbgi
