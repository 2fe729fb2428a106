#include "client/cli/gather_flags.h"

#include "server/render/render_options.h"

namespace pbgi::cli {

void GatherArgs::add_to(CLI::App* cmd) {
  flags.add(cmd, kRenderOptionTable, v1::GatherOptions::descriptor());
}

v1::GatherOptions GatherArgs::to_proto() const {
  v1::GatherOptions o;
  flags.apply(o);
  return o;
}

}  // namespace pbgi::cli
