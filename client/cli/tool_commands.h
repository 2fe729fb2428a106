// The subcommands of `pbgi` that run the pipeline in-process -- a scene
// read, lit and rendered or a page set decoded without a daemon -- live in
// a second executable, `pbgi-tools` (client/tools/), so that `pbgi` links
// only the client library. `pbgi bench ...` replaces itself by
// `pbgi-tools bench ...` (the executable beside it, same arguments): to the
// user both are one command line.
//
// Adding such a subcommand: its cmd_<name>.cpp in client/tools/, its name
// and description below (cmd_<name>.cpp reads the description from here).
#pragma once

#include "client/cli/cli_main.h"

#include <string_view>

namespace pbgi::cli {

inline constexpr ExternalCommand kToolCommands[] = {
    {"bench", "Speed against error: PBGI settings and path-tracer spp vs a converged reference"},
    {"inspect", "Describe a page set directory (manifest, counts, bytes, depths, page fill)"},
    {"reference", "Render an unbiased path-traced reference (multi-layer EXR of the AOVs)"},
};

// The description of tool command `name` (empty if it is none).
constexpr const char* tool_command_description(std::string_view name) {
  for (const ExternalCommand& c : kToolCommands) {
    if (name == c.name) return c.description;
  }
  return "";
}

// True if `name` is one of kToolCommands.
constexpr bool is_tool_command(std::string_view name) { return *tool_command_description(name) != '\0'; }

// Replaces this process by pbgi-tools, found beside this executable, with
// the same arguments. Returns only if that fails, after saying why on
// stderr; the return value is then the exit code (127).
int exec_tool(int argc, char** argv);

}  // namespace pbgi::cli
