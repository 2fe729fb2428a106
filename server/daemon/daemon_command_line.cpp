#include "server/daemon/daemon_command_line.h"

#include "pbgi_build_config.h"
#include "server/daemon/daemon_settings.h"

#include <CLI/CLI.hpp>

#include <ostream>

namespace pbgi::daemon {

CommandLine parse_command_line(int argc, const char* const* argv, const Environment& env,
                               std::ostream& out, std::ostream& err) {
  CLI::App app{"pbgid: point-based global illumination daemon"};
  app.set_version_flag("--version", std::string("pbgid ") + PBGI_VERSION);

  // Flags are parsed into pending changes first, then applied over the
  // config file and the environment, so that flags win. pbgid's own flags
  // come from its settings table (daemon_settings.h).
  std::string config;
  bool print_config = false;
  std::vector<PendingFlag> pending;
  app.add_option("--config", config, "TOML config file (default: $PBGI_CONFIG)");
  for (const DaemonSetting& setting : daemon_settings()) {
    if (setting.flag) setting.add_flag(setting, app, &pending);
  }
  app.add_flag("--print-config", print_config, "print the effective config as TOML and exit");

  CommandLine result;
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    result.exit_code = app.exit(e, out, err);
    return result;
  }

  try {
    // 1. Config file.
    DaemonOptions options;
    if (config.empty()) {
      if (const char* from_env = env("PBGI_CONFIG"); from_env && *from_env) config = from_env;
    }
    if (!config.empty()) options = load_daemon_config(config, std::move(options));

    // 2. Environment.
    apply_environment(options, env);

    // 3. Flags.
    for (const PendingFlag& apply : pending) apply(options);

    options.validate();
    if (print_config) {
      out << to_toml(options);
      result.exit_code = 0;
      return result;
    }
    result.options = std::move(options);
  } catch (const std::exception& e) {
    err << "pbgid: " << e.what() << '\n';
    result.exit_code = 2;
  }
  return result;
}

}  // namespace pbgi::daemon
