// Subcommands of the `pbgi` CLI register themselves here: each cmd_*.cpp
// defines one static CommandRegistrar, so main.cpp never lists them.
#pragma once

#include <CLI/CLI.hpp>

#include <functional>
#include <string>
#include <vector>

namespace pbgi::cli {

// Adds a subcommand to `app`; the callback it installs returns the exit code
// through *exit_code.
using CommandSetup = std::function<void(CLI::App& app, int* exit_code)>;

std::vector<std::pair<std::string, CommandSetup>>& command_registry();

struct CommandRegistrar {
  CommandRegistrar(std::string name, CommandSetup setup) {
    command_registry().emplace_back(std::move(name), std::move(setup));
  }
};

}  // namespace pbgi::cli
