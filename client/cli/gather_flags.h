// The gather flags `pbgi render` and `pbgi tile` share: how the daemon
// gathers each pixel's indirect light (pbgi.v1.GatherOptions; 0 or empty =
// the daemon's default, shown in brackets in --help and documented in
// server/gather/gather_options.h).
#pragma once

#include "pbgi/v1/pbgi.pb.h"

#include <CLI/CLI.hpp>

#include <cstdint>
#include <optional>
#include <string>

namespace pbgi::cli {

struct GatherArgs {
  uint32_t microbuffer_resolution = 0;
  float max_solid_angle = 0.f;
  float ao_max_distance = 0.f;
  uint32_t light_samples = 0;
  uint32_t pixel_samples = 0;
  std::string method;  // "pbgi" or "fpbgi"; "" = the daemon's default
  uint32_t clusters = 0;
  float epsilon = 0.f;
  float hdr_refine = 0.f;
  uint32_t glossy_max_resolution = 0;
  float glossy_importance = 0.f;
  std::optional<float> glossy_radiance_weight;  // unset = the daemon's default
  std::string interpolation;                    // "off" or "auto"; "" = the daemon's default
  std::optional<float> interpolation_tolerance;  // unset = the daemon's default
  uint32_t interpolation_spacing = 0;
  bool hide_dome = false;  // GatherOptions.dome_visible = false; unset = the daemon's default

  // Adds --mb-res, --max-solid-angle, --ao-max-distance, --light-samples,
  // --pixel-samples, --method, --clusters, --epsilon, --hdr-refine,
  // --glossy-max-res, --glossy-importance, --glossy-radiance-weight,
  // --interpolation, --interpolation-tolerance, --interpolation-spacing,
  // --hide-dome.
  void add_to(CLI::App* cmd);

  // The request message; the daemon validates the values and names the
  // field it refuses.
  v1::GatherOptions to_proto() const;
};

}  // namespace pbgi::cli
