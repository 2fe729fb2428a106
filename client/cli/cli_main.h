// The main() of both CLI executables, `pbgi` (client/cli/main.cpp) and
// `pbgi-tools` (client/tools/main.cpp): every subcommand registered in the
// executable (command.h), a guess for an unknown one, errors printed.
#pragma once

#include <span>

namespace pbgi::cli {

// A subcommand another executable runs: listed in --help and in the
// guesses for an unknown subcommand, never parsed here (tool_commands.h).
struct ExternalCommand {
  const char* name;
  const char* description;
};

// Parses argv against the registered subcommands (plus `external`, for
// --help) and runs the one named; returns the process's exit code.
int run_cli(int argc, char** argv, const char* description, std::span<const ExternalCommand> external = {});

}  // namespace pbgi::cli
