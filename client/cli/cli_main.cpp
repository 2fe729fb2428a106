#include "client/cli/cli_main.h"

#include "client/cli/command.h"
#include "client/cli/subcommand_suggestion.h"
#include "pbgi_build_config.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cstdio>
#include <exception>

namespace pbgi::cli {

std::vector<std::pair<std::string, CommandSetup>>& command_registry() {
  static std::vector<std::pair<std::string, CommandSetup>> registry;
  return registry;
}

int run_cli(int argc, char** argv, const char* description, std::span<const ExternalCommand> external) {
  CLI::App app{description};
  app.set_version_flag("--version", std::string("pbgi ") + PBGI_VERSION);
  app.require_subcommand(1);
  int exit_code = 0;
  // Registered and external subcommands together, by name (--help lists
  // them in the order they are added).
  auto& registry = command_registry();
  for (const ExternalCommand& c : external) {
    registry.emplace_back(c.name,
                          [c](CLI::App& a, int*) { a.add_subcommand(c.name, c.description)->prefix_command(); });
  }
  std::sort(registry.begin(), registry.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<std::string> names;
  for (auto& [name, setup] : registry) {
    setup(app, &exit_code);
    names.push_back(name);
  }
  // A first word that names no subcommand: say which one was meant, rather
  // than CLI11's "A subcommand is required".
  if (argc > 1 && argv[1][0] != '-' && std::find(names.begin(), names.end(), argv[1]) == names.end()) {
    const std::string guess = suggest_subcommand(argv[1], names);
    std::string all;
    for (const std::string& n : names) all += (all.empty() ? "" : ", ") + n;
    std::fprintf(stderr, "pbgi: unknown subcommand '%s'%s\nsubcommands: %s (pbgi --help)\n", argv[1],
                 guess.empty() ? "" : ("; did you mean '" + guess + "'?").c_str(), all.c_str());
    return static_cast<int>(CLI::ExitCodes::ExtrasError);
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  return exit_code;
}

}  // namespace pbgi::cli
