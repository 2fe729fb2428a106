#include "server/daemon/daemon_command_line.h"

#include "pbgi_build_config.h"

#include <CLI/CLI.hpp>

#include <ostream>

namespace pbgi::daemon {

CommandLine parse_command_line(int argc, const char* const* argv, const Environment& env,
                               std::ostream& out, std::ostream& err) {
  CLI::App app{"pbgid: point-based global illumination daemon"};
  app.set_version_flag("--version", std::string("pbgid ") + PBGI_VERSION);

  // Flags are parsed into these first, then applied over the config file
  // and the environment only if given, so that flags win.
  std::string config, listen, cache_dir, memory_budget, log_level, python;
  std::string tls_cert, tls_key, tls_client_ca, token_file, metrics_listen, log_format;
  std::string scene_memory_budget, staging_quota;
  std::vector<std::string> scene_roots, preload;
  uint32_t threads = 0, max_in_flight = 0, max_queued = 0;
  uint64_t max_surfels = 0;
  double grace = 0;
  bool print_config = false, allow_insecure_remote = false;

  app.add_option("--config", config, "TOML config file (default: $PBGI_CONFIG)");
  auto* o_listen = app.add_option("--listen", listen,
                                  "unix:PATH or HOST:PORT (default unix:<cache-dir>/pbgid.sock)");
  auto* o_roots = app.add_option("--scene-root", scene_roots,
                                 "directory scenes may be opened from (repeatable)");
  auto* o_cache = app.add_option("--cache-dir", cache_dir, "page sets are built here (./cache)");
  auto* o_budget =
      app.add_option("--memory-budget", memory_budget, "page cache budget, e.g. 2GiB, 512M");
  auto* o_threads = app.add_option("--threads", threads, "worker threads (0 = all cores)");
  auto* o_level = app.add_option("--log-level", log_level,
                                 "trace, debug, info, warn, error, critical, off");
  auto* o_python = app.add_option("--python", python, "interpreter with usd-core");
  auto* o_preload = app.add_option("--preload", preload, "open this scene at start (repeatable)");
  auto* o_grace = app.add_option("--shutdown-grace", grace,
                                 "seconds in-flight requests get on SIGTERM/SIGINT");
  auto* o_insecure = app.add_flag("--allow-insecure-remote", allow_insecure_remote,
                                  "allow plaintext TCP on a non-loopback address");
  auto* o_tls_cert = app.add_option("--tls-cert", tls_cert, "server certificate chain (PEM)");
  auto* o_tls_key = app.add_option("--tls-key", tls_key, "server private key (PEM)");
  auto* o_tls_ca = app.add_option("--tls-client-ca", tls_client_ca,
                                  "require client certificates signed by this CA (PEM)");
  auto* o_token = app.add_option("--auth-token-file", token_file,
                                 "file (mode 0600) with the bearer token clients must send "
                                 "($PBGI_AUTH_TOKEN gives the token itself)");
  auto* o_metrics = app.add_option("--metrics-listen", metrics_listen,
                                   "HOST:PORT for Prometheus GET /metrics (default: off)");
  auto* o_format = app.add_option("--log-format", log_format, "text or json");
  auto* o_scene_budget = app.add_option("--scene-memory-budget", scene_memory_budget,
                                        "unload least recently used scenes above this "
                                        "(e.g. 8GiB; 0 = never)");
  auto* o_in_flight = app.add_option("--max-in-flight", max_in_flight,
                                     "gathers/tiles computed at once (0 = 2 x threads)");
  auto* o_queued = app.add_option("--max-queued", max_queued,
                                  "more waiting; beyond, RESOURCE_EXHAUSTED + retry hint");
  auto* o_max_surfels = app.add_option("--max-surfels", max_surfels,
                                      "surfels one scene build may produce; more: RESOURCE_EXHAUSTED "
                                      "(0 = no limit)");
  auto* o_staging_quota = app.add_option("--staging-quota", staging_quota,
                                         "disk the builds in progress may stage together, e.g. 32GiB "
                                         "(0 = no limit)");
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
    if (o_listen->count()) options.listen = listen;
    if (o_roots->count()) options.scene_roots = scene_roots;
    if (o_cache->count()) options.cache_dir = cache_dir;
    if (o_budget->count()) options.memory_budget = memory_budget;
    if (o_threads->count()) options.threads = threads;
    if (o_level->count()) options.log_level = log_level;
    if (o_python->count()) options.python = python;
    if (o_preload->count()) options.preload = preload;
    if (o_grace->count()) options.shutdown_grace_seconds = grace;
    if (o_insecure->count()) options.allow_insecure_remote = allow_insecure_remote;
    if (o_in_flight->count()) options.service.limits.max_in_flight = max_in_flight;
    if (o_queued->count()) options.service.limits.max_queued = max_queued;
    if (o_tls_cert->count()) options.tls_cert = tls_cert;
    if (o_tls_key->count()) options.tls_key = tls_key;
    if (o_tls_ca->count()) options.tls_client_ca = tls_client_ca;
    if (o_token->count()) options.auth_token_file = token_file;
    if (o_metrics->count()) options.metrics_listen = metrics_listen;
    if (o_format->count()) options.log_format = log_format;
    if (o_scene_budget->count()) options.scene_memory_budget = scene_memory_budget;
    if (o_max_surfels->count()) options.service.limits.max_surfels = max_surfels;
    if (o_staging_quota->count()) options.staging_quota = staging_quota;

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
