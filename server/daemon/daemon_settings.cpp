#include "server/daemon/daemon_settings.h"

#include "common/byte_size.h"
#include "common/errors.h"

#include <fmt/format.h>

#include <charconv>
#include <cstring>
#include <string_view>

namespace pbgi::daemon {
namespace {

// Each row's field, reached from the options (some are nested).
template <class T>
using Field = T& (*)(DaemonOptions&);

uint32_t parse_unsigned(const char* variable, const char* text) {
  uint32_t value = 0;
  const char* end = text + std::strlen(text);
  auto [ptr, ec] = std::from_chars(text, end, value);
  if (ec != std::errc() || ptr != end) {
    throw InvalidArgument(fmt::format("environment {}='{}' is not an unsigned integer", variable, text));
  }
  return value;
}

// ':'-separated, empty items skipped (PBGI_SCENE_ROOTS).
std::vector<std::string> split_paths(std::string_view rest) {
  std::vector<std::string> items;
  while (!rest.empty()) {
    const size_t colon = rest.find(':');
    std::string_view item = rest.substr(0, colon);
    if (!item.empty()) items.emplace_back(item);
    rest = colon == std::string_view::npos ? std::string_view() : rest.substr(colon + 1);
  }
  return items;
}

// How a field of type T is read from an environment variable.
template <class T>
T from_env(const char* variable, const char* value);
template <>
std::string from_env<std::string>(const char*, const char* value) {
  return value;
}
template <>
std::vector<std::string> from_env<std::vector<std::string>>(const char*, const char* value) {
  return split_paths(value);
}
template <>
uint32_t from_env<uint32_t>(const char* variable, const char* value) {
  return parse_unsigned(variable, value);
}

// A flag taking a value (repeatable for a list), typed by CLI11.
template <class T, Field<T> F>
void add_option(const DaemonSetting& self, CLI::App& app, std::vector<PendingFlag>* pending) {
  app.add_option_function<T>(
      self.flag, [pending](const T& value) { pending->push_back([value](DaemonOptions& o) { F(o) = value; }); },
      self.help);
}

// A flag without a value sets the field to true (--flag=false: false).
template <Field<bool> F>
void add_switch(const DaemonSetting& self, CLI::App& app, std::vector<PendingFlag>* pending) {
  app.add_flag_function(
      self.flag,
      [pending](std::int64_t count) { pending->push_back([on = count > 0](DaemonOptions& o) { F(o) = on; }); },
      self.help);
}

template <class T, Field<T> F>
void set_from_env(const DaemonSetting& self, DaemonOptions& o, const char* value) {
  F(o) = from_env<T>(self.env, value);
}

// A byte size ("2GiB"): the variable is checked at once, naming it.
template <Field<std::string> F>
void set_byte_size_from_env(const DaemonSetting& self, DaemonOptions& o, const char* value) {
  parse_byte_size(value, fmt::format("environment {}", self.env));
  F(o) = value;
}

// A row with a flag and a variable (flag nullptr: the variable only).
template <class T, Field<T> F>
constexpr DaemonSetting setting(const char* flag, const char* env, const char* help) {
  return {flag, env, help, flag ? &add_option<T, F> : nullptr, &set_from_env<T, F>};
}
// A row with a flag only.
template <class T, Field<T> F>
constexpr DaemonSetting flag_only(const char* flag, const char* help) {
  return {flag, nullptr, help, &add_option<T, F>, nullptr};
}

// The fields.
std::string& listen(DaemonOptions& o) { return o.listen; }
std::vector<std::string>& scene_roots(DaemonOptions& o) { return o.scene_roots; }
std::string& cache_dir(DaemonOptions& o) { return o.cache_dir; }
std::string& memory_budget(DaemonOptions& o) { return o.memory_budget; }
std::string& request_memory(DaemonOptions& o) { return o.request_memory; }
std::string& page_cache_floor(DaemonOptions& o) { return o.page_cache_floor; }
std::string& page_cache_limit(DaemonOptions& o) { return o.page_cache_limit; }
uint32_t& threads(DaemonOptions& o) { return o.threads; }
std::string& log_level(DaemonOptions& o) { return o.log_level; }
std::string& python(DaemonOptions& o) { return o.python; }
std::vector<std::string>& preload(DaemonOptions& o) { return o.preload; }
double& shutdown_grace(DaemonOptions& o) { return o.shutdown_grace_seconds; }
bool& allow_insecure_remote(DaemonOptions& o) { return o.allow_insecure_remote; }
std::string& tls_cert(DaemonOptions& o) { return o.tls_cert; }
std::string& tls_key(DaemonOptions& o) { return o.tls_key; }
std::string& tls_client_ca(DaemonOptions& o) { return o.tls_client_ca; }
std::string& auth_token(DaemonOptions& o) { return o.auth_token; }
std::string& auth_token_file(DaemonOptions& o) { return o.auth_token_file; }
std::string& metrics_listen(DaemonOptions& o) { return o.metrics_listen; }
std::string& log_format(DaemonOptions& o) { return o.log_format; }
std::string& scene_memory_budget(DaemonOptions& o) { return o.scene_memory_budget; }
uint32_t& max_in_flight(DaemonOptions& o) { return o.service.limits.max_in_flight; }
uint32_t& max_queued(DaemonOptions& o) { return o.service.limits.max_queued; }
uint64_t& max_surfels(DaemonOptions& o) { return o.service.limits.max_surfels; }
std::string& staging_quota(DaemonOptions& o) { return o.staging_quota; }

using Strings = std::vector<std::string>;

const DaemonSetting kSettings[] = {
    setting<std::string, listen>("--listen", "PBGI_LISTEN",
                                 "unix:PATH or HOST:PORT (default unix:<cache-dir>/pbgid.sock)"),
    setting<Strings, scene_roots>("--scene-root", "PBGI_SCENE_ROOTS",
                                  "directory scenes may be opened from (repeatable)"),
    setting<std::string, cache_dir>("--cache-dir", "PBGI_CACHE_DIR", "page sets are built here (./cache)"),
    {"--memory-budget", "PBGI_MEMORY_BUDGET",
     "memory of the whole daemon: scenes, builds, request reserve and page cache, e.g. 2GiB, 512M",
     &add_option<std::string, memory_budget>, &set_byte_size_from_env<memory_budget>},
    flag_only<std::string, request_memory>("--request-memory",
                                           "share of --memory-budget kept for requests in flight (64MiB)"),
    flag_only<std::string, page_cache_floor>("--page-cache-floor",
                                             "the page cache never shrinks below this for scenes (32MiB)"),
    flag_only<std::string, page_cache_limit>("--page-cache-limit",
                                             "the page cache holds at most this (0 = what the budget leaves)"),
    setting<uint32_t, threads>("--threads", "PBGI_THREADS", "worker threads (0 = all cores)"),
    setting<std::string, log_level>("--log-level", "PBGI_LOG_LEVEL", "trace, debug, info, warn, error, critical, off"),
    setting<std::string, python>("--python", "PBGI_PYTHON", "interpreter with usd-core"),
    flag_only<Strings, preload>("--preload", "open this scene at start (repeatable)"),
    flag_only<double, shutdown_grace>("--shutdown-grace", "seconds in-flight requests get on SIGTERM/SIGINT"),
    {"--allow-insecure-remote", nullptr, "allow plaintext TCP on a non-loopback address",
     &add_switch<allow_insecure_remote>, nullptr},
    flag_only<std::string, tls_cert>("--tls-cert", "server certificate chain (PEM)"),
    flag_only<std::string, tls_key>("--tls-key", "server private key (PEM)"),
    flag_only<std::string, tls_client_ca>("--tls-client-ca", "require client certificates signed by this CA (PEM)"),
    // The token itself is a secret: from the environment only.
    setting<std::string, auth_token>(nullptr, "PBGI_AUTH_TOKEN", "the bearer token clients must send"),
    setting<std::string, auth_token_file>("--auth-token-file", "PBGI_AUTH_TOKEN_FILE",
                                          "file (mode 0600) with the bearer token clients must send "
                                          "($PBGI_AUTH_TOKEN gives the token itself)"),
    setting<std::string, metrics_listen>("--metrics-listen", "PBGI_METRICS_LISTEN",
                                         "HOST:PORT for Prometheus GET /metrics (default: off)"),
    flag_only<std::string, log_format>("--log-format", "text or json"),
    flag_only<std::string, scene_memory_budget>("--scene-memory-budget",
                                                "sub-limit of --memory-budget on open scenes: "
                                                "unload least recently used ones above it (e.g. 8GiB; 0 = none)"),
    flag_only<uint32_t, max_in_flight>("--max-in-flight", "gathers/tiles computed at once (0 = 2 x threads)"),
    flag_only<uint32_t, max_queued>("--max-queued", "more waiting; beyond, RESOURCE_EXHAUSTED + retry hint"),
    flag_only<uint64_t, max_surfels>("--max-surfels",
                                     "surfels one scene build may produce; more: RESOURCE_EXHAUSTED "
                                     "(0 = no limit)"),
    flag_only<std::string, staging_quota>("--staging-quota",
                                          "disk the builds in progress may stage together, e.g. 32GiB "
                                          "(0 = no limit)"),
};

}  // namespace

std::span<const DaemonSetting> daemon_settings() { return kSettings; }

}  // namespace pbgi::daemon
