#include "server/volumes/fog_options.h"

#include "common/errors.h"

#include <fmt/format.h>

#include <cmath>

namespace pbgi {

void FogOptions::validate() const {
  if (!(extinction_per_density >= 0.f) || !std::isfinite(extinction_per_density))
    throw InvalidArgument(fmt::format("fog.extinction_per_density = {}: must be finite and >= 0", extinction_per_density));
  for (int c = 0; c < 3; ++c)
    if (!(albedo[c] >= 0.f && albedo[c] <= 1.f)) throw InvalidArgument("fog.albedo: each channel must be in [0, 1]");
  if (!(step_voxels > 0.f) || !std::isfinite(step_voxels))
    throw InvalidArgument(fmt::format("fog.step_voxels = {}: must be > 0", step_voxels));
  if (light_samples == 0) throw InvalidArgument("fog.light_samples must be >= 1");
  if (max_block_voxels == 0 || (max_block_voxels & (max_block_voxels - 1)) != 0)
    throw InvalidArgument(fmt::format("fog.max_block_voxels = {}: must be a power of two", max_block_voxels));
}

}  // namespace pbgi
