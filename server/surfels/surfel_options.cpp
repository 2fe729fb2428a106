#include "server/surfels/surfel_options.h"

#include "common/errors.h"

#include <fmt/format.h>

#include <cmath>

namespace pbgi {

std::string to_string(SurfelSampler sampler) { return std::string(options::enum_name(sampler)); }

SurfelSampler parse_surfel_sampler(const std::string& name) {
  if (const auto sampler = options::parse_enum<SurfelSampler>(name)) return *sampler;
  throw InvalidArgument(fmt::format("sampler '{}' is not {}", name,
                                    options::enum_name_list<SurfelSampler>(" or ")));
}

void SurfelOptions::validate() const {
  if (sampler != SurfelSampler::kUniform && sampler != SurfelSampler::kPoisson) {
    throw InvalidArgument(fmt::format("surfels.sampler = {}: unknown sampler", int(sampler)));
  }
  if (!std::isfinite(spacing) || spacing < 0.f) {
    throw InvalidArgument(fmt::format("surfels.spacing = {}: must be finite and >= 0", spacing));
  }
  // The tree refuses more than 2^31 surfels (storage/tree/tree_builder.h).
  if (!adaptive() && spacing == 0.f && (target_surfels == 0 || target_surfels > (1ull << 31))) {
    throw InvalidArgument(fmt::format(
        "surfels.target_surfels = {}: must be in [1, 2^31] when spacing is 0", target_surfels));
  }
  if (!(glossy_roughness >= 0.f && glossy_roughness <= 1.f)) {
    throw InvalidArgument(fmt::format("surfels.glossy_roughness = {}: must be in [0, 1]", glossy_roughness));
  }
  if (light_samples == 0 || light_samples > 4096) {
    throw InvalidArgument(
        fmt::format("surfels.light_samples = {}: must be in [1, 4096]", light_samples));
  }
  if (batch_surfels < 1024 || batch_surfels > (1u << 24)) {
    throw InvalidArgument(fmt::format("surfels.batch_surfels = {}: must be in [1024, 2^24]", batch_surfels));
  }
  if (!adaptive()) return;
  if (sampler != SurfelSampler::kPoisson) {
    throw InvalidArgument("surfels.camera = \"" + camera + "\": camera-adaptive spacing needs the poisson sampler");
  }
  if (image_width == 0 || image_height == 0 || image_width > 65536 || image_height > 65536) {
    throw InvalidArgument(fmt::format("surfels.image_width/height = {}x{}: must be in [1, 65536]", image_width,
                                      image_height));
  }
  if (!std::isfinite(pixel_footprint) || pixel_footprint <= 0.f) {
    throw InvalidArgument(fmt::format("surfels.pixel_footprint = {}: must be finite and > 0", pixel_footprint));
  }
  if (!std::isfinite(min_spacing) || min_spacing < 0.f) {
    throw InvalidArgument(fmt::format("surfels.min_spacing = {}: must be finite and >= 0", min_spacing));
  }
  if (!std::isfinite(offscreen_factor) || offscreen_factor < 1.f || offscreen_factor > 1e4f) {
    throw InvalidArgument(fmt::format("surfels.offscreen_factor = {}: must be in [1, 1e4]", offscreen_factor));
  }
  if (!std::isfinite(frustum_margin) || frustum_margin < 0.f || frustum_margin > 10.f) {
    throw InvalidArgument(fmt::format("surfels.frustum_margin = {}: must be in [0, 10]", frustum_margin));
  }
}

}  // namespace pbgi
