#include "server/render/render_options.h"

#include "common/errors.h"

#include <fmt/format.h>

#include <bit>

namespace pbgi {

const char* interpolation_mode_name(InterpolationMode mode) {
  const std::string_view name = options::enum_name(mode);
  return name.empty() ? "?" : name.data();  // the names are string literals
}

std::optional<InterpolationMode> parse_interpolation_mode(std::string_view name) {
  return options::parse_enum<InterpolationMode>(name);
}

void InterpolationOptions::validate() const {
  if (!(tolerance > 0.f && tolerance <= 1.f)) {
    throw InvalidArgument(fmt::format("render.interpolation_tolerance = {}: must be in (0, 1]", tolerance));
  }
  if (spacing == 0 || spacing > 64 || !std::has_single_bit(spacing)) {
    throw InvalidArgument(
        fmt::format("render.interpolation_spacing = {}: must be a power of two in [1, 64]", spacing));
  }
}


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
  if (edge_samples > 4096) {
    throw InvalidArgument(fmt::format("render.edge_samples = {}: must be at most 4096", edge_samples));
  }
}

}  // namespace pbgi
