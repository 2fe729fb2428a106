// pbgid's command line: CLI11 flags over PBGI_* environment variables over
// the TOML file named by --config (or PBGI_CONFIG) over the defaults.
#pragma once

#include "server/daemon/daemon_options.h"

#include <iosfwd>
#include <optional>

namespace pbgi::daemon {

struct CommandLine {
  // Set when the daemon should run; unset when it should exit with
  // exit_code (--help, --version, --print-config or an error, which has
  // then been written to `err`).
  std::optional<DaemonOptions> options;
  int exit_code = 0;
};

// Never throws: configuration errors (unknown TOML key, bad size, bad
// address...) are written to `err` with exit code 2.
CommandLine parse_command_line(int argc, const char* const* argv, const Environment& env,
                               std::ostream& out, std::ostream& err);

}  // namespace pbgi::daemon
