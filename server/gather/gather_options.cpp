#include "server/gather/gather_options.h"

#include "common/errors.h"

#include <cmath>
#include <string>

namespace pbgi {

void GatherOptions::validate() const {
  if (method != GatherMethod::kPbgi && method != GatherMethod::kFpbgi) {
    throw InvalidArgument("GatherOptions.method = " + std::to_string(int(method)) +
                          ": unknown gather method");
  }
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
  if (clusters < 1 || clusters > kMaxClusters) {
    throw InvalidArgument("GatherOptions.clusters = " + std::to_string(clusters) +
                          ": must be in [1, " + std::to_string(kMaxClusters) + "]");
  }
  if (!(std::isfinite(epsilon) && epsilon >= 0.f && epsilon <= kMaxEpsilon)) {
    throw InvalidArgument("GatherOptions.epsilon = " + std::to_string(epsilon) +
                          ": must be in [0, " + std::to_string(kMaxEpsilon) + "] (0 = auto)");
  }
  if (!(std::isfinite(hdr_refine) && hdr_refine >= 0.f)) {
    throw InvalidArgument("GatherOptions.hdr_refine = " + std::to_string(hdr_refine) +
                          ": must be finite and >= 0 (0 = off)");
  }
  if (glossy_max_resolution < kMinMicrobufferResolution ||
      glossy_max_resolution > kMaxGlossyResolution) {
    throw InvalidArgument(
        "GatherOptions.glossy_max_resolution = " + std::to_string(glossy_max_resolution) +
        ": must be in [" + std::to_string(kMinMicrobufferResolution) + ", " +
        std::to_string(kMaxGlossyResolution) + "]");
  }
  if (!(glossy_radiance_weight >= 0.f && glossy_radiance_weight <= 1.f)) {
    throw InvalidArgument("GatherOptions.glossy_radiance_weight = " + std::to_string(glossy_radiance_weight) +
                          ": must be in [0, 1]");
  }
  if (!(std::isfinite(glossy_importance) && glossy_importance > 0.f && glossy_importance <= 1.f)) {
    throw InvalidArgument("GatherOptions.glossy_importance = " +
                          std::to_string(glossy_importance) + ": must be in (0, 1]");
  }
}

}  // namespace pbgi
