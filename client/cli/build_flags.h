// The build flags `pbgi render` and `pbgi tile` share: they choose which
// tree the daemon builds or reuses for a scene (pbgi.v1.BuildOptions; a
// flag not given = the daemon's default from its config file). The flags
// are OpenOptions' table's (server/engine/open_options.h): --target-surfels,
// --surfel-spacing, --build-light-samples, --bounces, --payload,
// --leaf-format, --lut-entries, --sampler, --spacing-camera,
// --pixel-footprint, --glossy-roughness, --glossy-resolution,
// --wavelet-threshold, --fog-extinction, --fog-albedo, --bounce-splatting,
// --bounce-view-solid-angle, --bounce-receiver-stride, --bounce-mb-res,
// --bounce-solid-angle and --default-light.
#pragma once

#include "client/cli/option_flags.h"
#include "pbgi/v1/pbgi.pb.h"

#include <CLI/CLI.hpp>

#include <cstdint>

namespace pbgi::cli {

struct BuildArgs {
  OptionFlags flags;

  void add_to(CLI::App* cmd);

  // The request message. Throws InvalidArgument for a --payload value the
  // daemon cannot serve (it is never dropped silently); other unknown
  // names are refused by the daemon, naming the field. `image_width` x
  // `image_height` is the image a --spacing-camera spacing is for (the
  // one the command renders); 0 = the daemon's default.
  v1::BuildOptions to_proto(uint32_t image_width = 0, uint32_t image_height = 0) const;
};

}  // namespace pbgi::cli
