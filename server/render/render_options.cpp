#include "server/render/tile_renderer.h"

#include "storage/format/errors.h"

#include <fmt/format.h>

namespace pbgi {

void RenderOptions::validate() const {
  gather.validate();
  interpolation.validate();
  if (light_samples == 0 || light_samples > 4096) {
    throw InvalidArgument(
        fmt::format("render.light_samples = {}: must be in [1, 4096]", light_samples));
  }
  if (pixel_samples == 0 || pixel_samples > 1024) {
    throw InvalidArgument(
        fmt::format("render.pixel_samples = {}: must be in [1, 1024]", pixel_samples));
  }
}

}  // namespace pbgi
