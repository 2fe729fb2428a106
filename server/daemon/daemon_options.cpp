#include "server/daemon/daemon_options.h"

#include "common/byte_size.h"
#include "common/errors.h"
#include "pbgi_build_config.h"
#include "server/daemon/daemon_settings.h"
#include "server/daemon/listen_address.h"
#include "server/daemon/toml_options.h"

#include <fmt/format.h>
#include <toml++/toml.h>

#include <array>
#include <cerrno>
#include <charconv>
#include <cstring>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>

namespace fs = std::filesystem;

namespace pbgi::daemon {
namespace {

constexpr std::array<std::string_view, 7> kLogLevels = {"trace", "debug",    "info", "warn",
                                                        "error", "critical", "off"};

// DaemonOptions' own options, in three sections (the stages' options are
// in their tables: [gather] RenderOptions, [build] OpenOptions, [fog]
// FogOptions, [limits] RequestLimits).
const auto kTopTable = options::table(
    // Printed with the default filled in; compared the same way.
    options::custom<DaemonOptions, std::string>(
        "listen", [](const DaemonOptions& o) { return o.effective_listen(); },
        [](DaemonOptions& o, const std::string& v) { o.listen = v; }),
    options::field<&DaemonOptions::scene_roots>("scene_roots"), options::field<&DaemonOptions::cache_dir>("cache_dir"),
    options::field<&DaemonOptions::memory_budget>("memory_budget"),
    options::field<&DaemonOptions::request_memory>("request_memory"),
    options::field<&DaemonOptions::page_cache_floor>("page_cache_floor"),
    options::field<&DaemonOptions::page_cache_limit>("page_cache_limit"),
    options::field<&DaemonOptions::threads>("threads"), options::field<&DaemonOptions::log_level>("log_level"),
    options::field<&DaemonOptions::python>("python"), options::field<&DaemonOptions::preload>("preload"),
    options::field<&DaemonOptions::allow_insecure_remote>("allow_insecure_remote"),
    options::field<&DaemonOptions::shutdown_grace_seconds>("shutdown_grace_seconds"),
    options::field<&DaemonOptions::scene_memory_budget>("scene_memory_budget"),
    options::field<&DaemonOptions::staging_quota>("staging_quota"),
    options::field<&DaemonOptions::log_format>("log_format"),
    options::field<&DaemonOptions::metrics_listen>("metrics_listen"));

const auto kLimitsTable = options::table(
    options::nest<&DaemonOptions::service, &service::ServiceOptions::limits>(service::kRequestLimitsTable),
    options::field<&DaemonOptions::max_message_size>("max_message_size"));

// The token itself (auth_token) is a secret: never in the file.
const auto kSecurityTable = options::table(options::field<&DaemonOptions::tls_cert>("tls_cert"),
                                           options::field<&DaemonOptions::tls_key>("tls_key"),
                                           options::field<&DaemonOptions::tls_client_ca>("tls_client_ca"),
                                           options::field<&DaemonOptions::auth_token_file>("auth_token_file"));

// The sections of the file, in the order --print-config writes them.
// fn(section, table, the section's struct in each of options...).
template <class Fn, class... D>
void for_each_section(Fn&& fn, D&... o) {
  fn("", kTopTable, o...);
  fn("gather", kRenderOptionTable, o.service.defaults.render...);
  fn("build", kOpenOptionTable, o.service.defaults.open...);
  fn("fog", kFogOptionTable, o.service.defaults.open.fog...);
  fn("limits", kLimitsTable, o...);
  fn("security", kSecurityTable, o...);
}

}  // namespace

DaemonOptions::DaemonOptions() : python(PBGI_PYTHON) {}

std::string DaemonOptions::effective_listen() const {
  if (!listen.empty()) return listen;
  return "unix:" + (fs::path(cache_dir) / "pbgid.sock").string();
}

uint64_t DaemonOptions::memory_budget_bytes() const {
  return parse_byte_size(memory_budget, "memory_budget");
}

uint64_t DaemonOptions::request_memory_bytes() const { return parse_byte_size(request_memory, "request_memory"); }

uint64_t DaemonOptions::page_cache_floor_bytes() const { return parse_byte_size(page_cache_floor, "page_cache_floor"); }
uint64_t DaemonOptions::page_cache_limit_bytes() const { return parse_byte_size(page_cache_limit, "page_cache_limit"); }

uint64_t DaemonOptions::scene_memory_budget_bytes() const {
  return parse_byte_size(scene_memory_budget, "scene_memory_budget");
}

uint64_t DaemonOptions::staging_quota_bytes() const {
  return parse_byte_size(staging_quota, "staging_quota");
}

uint64_t DaemonOptions::max_message_bytes() const {
  return parse_byte_size(max_message_size, "limits.max_message_size");
}

void DaemonOptions::validate() const {
  const ListenAddress address = parse_listen_address(effective_listen());
  if (tls_cert.empty() != tls_key.empty()) {
    throw InvalidArgument("security.tls_cert and security.tls_key must be given together");
  }
  if (!tls_client_ca.empty() && tls_cert.empty()) {
    throw InvalidArgument("security.tls_client_ca needs security.tls_cert and tls_key");
  }
  if (!address.is_loopback() && !tls() && !allow_insecure_remote) {
    throw InvalidArgument(fmt::format(
        "listen '{}' is not a loopback address and TLS is not configured; set "
        "security.tls_cert and tls_key, use a unix socket or 127.0.0.1, or set "
        "allow_insecure_remote",
        effective_listen()));
  }
  if (!metrics_listen.empty()) {
    const ListenAddress metrics = parse_listen_address(metrics_listen);
    if (metrics.kind != ListenAddress::Kind::Tcp) {
      throw InvalidArgument(fmt::format("metrics_listen '{}' must be HOST:PORT", metrics_listen));
    }
    // Off loopback the metrics (scene paths, load) need the bearer token,
    // unless plaintext without one was allowed explicitly.
    const bool token = !auth_token.empty() || !auth_token_file.empty();
    if (!metrics.is_loopback() && !token && !allow_insecure_remote) {
      throw InvalidArgument(fmt::format(
          "metrics_listen '{}' is not a loopback address and no bearer token is configured; set "
          "security.auth_token_file (or PBGI_AUTH_TOKEN), listen on 127.0.0.1, or set "
          "allow_insecure_remote",
          metrics_listen));
    }
  }
  if (log_format != "text" && log_format != "json") {
    throw InvalidArgument(fmt::format("log_format '{}' is not text or json", log_format));
  }
  scene_memory_budget_bytes();
  page_cache_limit_bytes();
  staging_quota_bytes();
  if (cache_dir.empty()) throw InvalidArgument("cache_dir is empty");
  if (memory_budget_bytes() < (1u << 20)) {
    throw InvalidArgument(fmt::format("memory_budget '{}' is below 1MiB", memory_budget));
  }
  if (request_memory_bytes() + page_cache_floor_bytes() >= memory_budget_bytes()) {
    throw InvalidArgument(
        fmt::format("memory_budget '{}' leaves nothing for scenes after request_memory '{}' "
                    "and page_cache_floor '{}'",
                    memory_budget, request_memory, page_cache_floor));
  }
  const uint64_t message = max_message_bytes();
  if (message < (1u << 20) || message > uint64_t(std::numeric_limits<int>::max())) {
    throw InvalidArgument(fmt::format("limits.max_message_size '{}' must be 1MiB..2GiB",
                                      max_message_size));
  }
  bool known_level = false;
  for (std::string_view level : kLogLevels) known_level |= level == log_level;
  if (!known_level) {
    throw InvalidArgument(fmt::format(
        "log_level '{}' is not one of trace, debug, info, warn, error, critical, off", log_level));
  }
  if (!(shutdown_grace_seconds >= 0)) {
    throw InvalidArgument("shutdown_grace_seconds must be >= 0");
  }
  if (python.empty()) throw InvalidArgument("python is empty");
  const service::RequestLimits& limits = service.limits;
  if (limits.max_receivers == 0 || limits.max_image_side == 0 || limits.max_tile_pixels == 0) {
    throw InvalidArgument("limits.max_receivers, max_image_side and max_tile_pixels must be > 0");
  }
  // The stages check their own options, naming the field.
  service.defaults.render.validate();
  service.defaults.open.surfels.validate();
  service.defaults.open.tree.validate();
  service.defaults.open.bounce.validate();
}

DaemonOptions parse_daemon_config(std::string_view toml_text, const std::string& source,
                                  DaemonOptions base) {
  toml::table root;
  try {
    root = toml::parse(toml_text, source);
  } catch (const toml::parse_error& e) {
    throw InvalidArgument(fmt::format("config '{}' line {} column {}: {}", source,
                                      e.source().begin.line, e.source().begin.column,
                                      e.description()));
  }

  DaemonOptions out = std::move(base);
  TableReader top(root, "", source);
  for_each_section(
      [&](const char* section, const auto& table, auto& values) {
        if (*section == 0) {
          read_fields(top, table, values);
        } else if (const toml::table* sub = top.table(section)) {
          TableReader reader(*sub, section, source);
          read_fields(reader, table, values);
          reader.reject_unknown();
          if (std::string_view(section) == "fog") out.service.defaults.open.fog.validate();  // names fog.albedo
        }
      },
      out);
  top.reject_unknown();
  return out;
}

DaemonOptions load_daemon_config(const fs::path& file, DaemonOptions base) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw IoError(fmt::format("cannot read config file '{}': {}", file.string(), std::strerror(errno)));
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw IoError(fmt::format("error reading config file '{}'", file.string()));
  return parse_daemon_config(text.str(), file.string(), std::move(base));
}

std::string to_toml(const DaemonOptions& o) {
  std::ostringstream out;
  TomlWriter writer(out);
  out << "# pbgid effective configuration\n";
  for_each_section(
      [&](const char* section, const auto& table, const auto& values) {
        if (*section) out << "\n[" << section << "]\n";
        write_fields(writer, table, values);
      },
      o);
  // The token itself is a secret: only whether one came from the environment.
  if (!o.auth_token.empty()) out << "# auth token: set by PBGI_AUTH_TOKEN\n";
  return out.str();
}

Environment process_environment() {
  return [](const char* name) -> const char* { return std::getenv(name); };
}

void apply_environment(DaemonOptions& o, const Environment& env) {
  auto get = [&](const char* name) -> const char* {
    const char* value = env(name);
    return value && *value ? value : nullptr;
  };
  // Set but empty would silently turn authentication off: refuse.
  for (const char* name : {"PBGI_AUTH_TOKEN", "PBGI_AUTH_TOKEN_FILE"}) {
    const char* value = env(name);
    if (value && !*value) {
      throw InvalidArgument(fmt::format("environment {} is set but empty: unset it to run without a "
                                        "bearer token, or give the token",
                                        name));
    }
  }
  for (const DaemonSetting& setting : daemon_settings()) {
    if (!setting.env) continue;
    if (const char* v = get(setting.env)) setting.apply_env(setting, o, v);
  }
}

bool operator==(const DaemonOptions& a, const DaemonOptions& b) {
  bool same = a.auth_token == b.auth_token;
  for_each_section(
      [&](const char*, const auto& table, const auto& x, const auto& y) {
        same = same && options::equal(table, x, y);
      },
      a, b);
  return same;
}

}  // namespace pbgi::daemon
