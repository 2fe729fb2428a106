#include "client/cli/build_flags.h"

#include "server/engine/open_options.h"

namespace pbgi::cli {

void BuildArgs::add_to(CLI::App* cmd) {
  flags.add(cmd, kOpenOptionTable, v1::BuildOptions::descriptor());
}

v1::BuildOptions BuildArgs::to_proto(uint32_t image_width, uint32_t image_height) const {
  v1::BuildOptions build;
  flags.apply(build);
  if (!build.spacing_camera().empty()) {
    build.set_spacing_image_width(image_width);
    build.set_spacing_image_height(image_height);
  }
  return build;
}

}  // namespace pbgi::cli
