// pbgi: the command-line client. Thin: each subcommand lives in cmd_*.cpp.
#include "client/cli/command.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <exception>

namespace pbgi::cli {
std::vector<std::pair<std::string, CommandSetup>>& command_registry() {
  static std::vector<std::pair<std::string, CommandSetup>> registry;
  return registry;
}
}  // namespace pbgi::cli

int main(int argc, char** argv) {
  CLI::App app{"pbgi: point-based global illumination client tools"};
  app.require_subcommand(1);
  int exit_code = 0;
  auto& registry = pbgi::cli::command_registry();
  std::sort(registry.begin(), registry.end(),
            [](const auto& a, const auto& b) { return a.first < b.first; });
  for (auto& [name, setup] : registry) setup(app, &exit_code);
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
