// pbgid's own settings on its command line and in its environment, one row
// each: the flag, the PBGI_* variable, the help text and the field they
// set. daemon_command_line.cpp derives the flags from the table and
// apply_environment() (daemon_options.h) the variables; the config file's
// keys are the tables in daemon_options.cpp. (The stages' options -- the
// [gather], [build], [fog] and [limits] defaults -- have no flags on
// pbgid: they are set in the config file.)
//
// Adding a setting: its field in DaemonOptions (with its config key in
// daemon_options.cpp), then a row below; nothing else.
#pragma once

#include "server/daemon/daemon_options.h"

#include <CLI/CLI.hpp>

#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

namespace pbgi::daemon {

// What a flag given on the command line does once the config file and the
// environment have been applied (flags win).
using PendingFlag = std::function<void(DaemonOptions&)>;

struct DaemonSetting {
  const char* flag;  // "--listen"; nullptr: environment only
  const char* env;   // "PBGI_LISTEN"; nullptr: flag only
  const char* help;
  // Adds the flag to `app`; when given, pushes what it sets onto *pending.
  void (*add_flag)(const DaemonSetting& self, CLI::App& app, std::vector<PendingFlag>* pending);
  // Sets the field from the variable's (non-empty) value; throws
  // InvalidArgument naming the variable if it is malformed.
  void (*apply_env)(const DaemonSetting& self, DaemonOptions& options, const char* value);
};

// The rows, in --help's order.
std::span<const DaemonSetting> daemon_settings();

}  // namespace pbgi::daemon
