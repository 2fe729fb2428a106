// The gather flags `pbgi render` and `pbgi tile` share: how the daemon
// gathers each pixel's indirect light (pbgi.v1.GatherOptions; a flag not
// given = the daemon's default, shown in brackets in --help and documented
// in server/render/render_options.h). The flags are RenderOptions' table's
// (server/render/render_options.h): --mb-res, --max-solid-angle,
// --ao-max-distance, --light-samples, --pixel-samples, --method,
// --clusters, --epsilon, --hdr-refine, --glossy-max-res,
// --glossy-importance, --glossy-radiance-weight, --interpolation,
// --interpolation-tolerance, --interpolation-spacing, --hide-dome.
#pragma once

#include "client/cli/option_flags.h"
#include "pbgi/v1/pbgi.pb.h"

#include <CLI/CLI.hpp>

namespace pbgi::cli {

struct GatherArgs {
  OptionFlags flags;

  void add_to(CLI::App* cmd);

  // The request message; the daemon validates the values and names the
  // field it refuses.
  v1::GatherOptions to_proto() const;
};

}  // namespace pbgi::cli
