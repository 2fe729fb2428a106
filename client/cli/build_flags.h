// The build flags `pbgi render` and `pbgi tile` share: they choose which
// tree the daemon builds or reuses for a scene (pbgi.v1.BuildOptions; 0 or
// empty = the daemon's default from its config file).
#pragma once

#include "pbgi/v1/pbgi.pb.h"

#include <CLI/CLI.hpp>

#include <cstdint>
#include <optional>
#include <string>

namespace pbgi::cli {

struct BuildArgs {
  uint64_t target_surfels = 0;
  float surfel_spacing = 0.f;
  uint32_t light_samples = 0;
  uint32_t bounces = 0;
  std::string payload;
  uint32_t lut_entries = 0;
  std::string leaf_format;     // "relative" / "half"; "" = the daemon's default
  std::string sampler;         // "uniform" / "poisson"; "" = the daemon's default
  std::string spacing_camera;  // camera-adaptive spacing; "" = absolute
  float pixel_footprint = 0.f;
  std::optional<float> glossy_roughness;   // unset = the daemon's default
  uint32_t glossy_resolution = 0;          // 0 = the daemon's default
  std::optional<float> wavelet_threshold;  // unset = the daemon's default
  float fog_extinction = 0.f;              // 0 = the daemon's default
  std::optional<float> fog_albedo;         // unset = the daemon's default
  std::optional<bool> bounce_splatting;    // unset = the daemon's default
  std::optional<float> bounce_view_solid_angle;  // unset = the daemon's default
  bool default_light = false;                    // false = the daemon's default
  std::optional<uint32_t> bounce_receiver_stride;         // unset = the daemon's default
  std::optional<uint32_t> bounce_microbuffer_resolution;  // unset = the daemon's default
  std::optional<float> bounce_max_solid_angle;            // unset = the daemon's default

  // Adds --target-surfels, --surfel-spacing, --build-light-samples,
  // --bounces, --payload, --leaf-format, --lut-entries, --sampler, --spacing-camera,
  // --pixel-footprint, --glossy-roughness, --glossy-resolution,
  // --wavelet-threshold, --fog-extinction, --fog-albedo,
  // --bounce-splatting, --bounce-view-solid-angle, --bounce-receiver-stride,
  // --bounce-mb-res, --bounce-solid-angle and --default-light to `cmd`.
  void add_to(CLI::App* cmd);

  // The request message. Throws InvalidArgument for a --payload value the
  // daemon cannot serve (it is never dropped silently); other unknown
  // names are refused by the daemon, naming the field. `image_width` x
  // `image_height` is the image a --spacing-camera spacing is for (the
  // one the command renders); 0 = the daemon's default.
  v1::BuildOptions to_proto(uint32_t image_width = 0, uint32_t image_height = 0) const;
};

}  // namespace pbgi::cli
