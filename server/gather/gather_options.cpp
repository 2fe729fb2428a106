#include "server/gather/gather_options.h"

#include "storage/format/errors.h"

#include <cmath>
#include <string>

namespace pbgi {

void GatherOptions::validate() const {
  if (microbuffer_resolution < kMinMicrobufferResolution ||
      microbuffer_resolution > kMaxMicrobufferResolution) {
    throw InvalidArgument(
        "GatherOptions.microbuffer_resolution = " + std::to_string(microbuffer_resolution) +
        ": must be in [" + std::to_string(kMinMicrobufferResolution) + ", " +
        std::to_string(kMaxMicrobufferResolution) + "]");
  }
  if (!(std::isfinite(max_solid_angle) && max_solid_angle > 0.f &&
        max_solid_angle <= kMaxMaxSolidAngle)) {
    throw InvalidArgument("GatherOptions.max_solid_angle = " + std::to_string(max_solid_angle) +
                          ": must be in (0, " + std::to_string(kMaxMaxSolidAngle) + "] steradians");
  }
  if (!(std::isfinite(ao_max_distance) && ao_max_distance >= 0.f)) {
    throw InvalidArgument("GatherOptions.ao_max_distance = " + std::to_string(ao_max_distance) +
                          ": must be finite and >= 0 (0 = unbounded)");
  }
}

}  // namespace pbgi
