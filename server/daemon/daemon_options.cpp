#include "server/daemon/daemon_options.h"

#include "pbgi_build_config.h"
#include "server/daemon/byte_size.h"
#include "server/daemon/listen_address.h"
#include "storage/format/errors.h"

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

// Reads the keys of one TOML table into fields, remembering which keys it
// consumed so that whatever is left over can be reported as unknown.
class TableReader {
 public:
  TableReader(const toml::table& table, std::string prefix, const std::string& source)
      : table_(table), prefix_(std::move(prefix)), source_(source) {}

  void read(const char* key, std::string& out) {
    if (const toml::node* node = find(key)) {
      if (!node->is_string()) throw type_error(key, "a string");
      out = node->as_string()->get();
    }
  }
  void read(const char* key, bool& out) {
    if (const toml::node* node = find(key)) {
      if (!node->is_boolean()) throw type_error(key, "true or false");
      out = node->as_boolean()->get();
    }
  }
  template <class T>
    requires std::is_integral_v<T> && std::is_unsigned_v<T>
  void read(const char* key, T& out) {
    if (const toml::node* node = find(key)) {
      if (!node->is_integer()) throw type_error(key, "an integer");
      const int64_t v = node->as_integer()->get();
      if (v < 0 || static_cast<uint64_t>(v) > std::numeric_limits<T>::max()) {
        throw InvalidArgument(fmt::format("config '{}': key '{}' = {} is out of range 0..{}",
                                          source_, name(key), v, std::numeric_limits<T>::max()));
      }
      out = static_cast<T>(v);
    }
  }
  template <class T>
    requires std::is_floating_point_v<T>
  void read(const char* key, T& out) {
    if (const toml::node* node = find(key)) {
      if (node->is_floating_point()) {
        out = static_cast<T>(node->as_floating_point()->get());
      } else if (node->is_integer()) {
        out = static_cast<T>(node->as_integer()->get());
      } else {
        throw type_error(key, "a number");
      }
    }
  }
  void read(const char* key, std::vector<std::string>& out) {
    if (const toml::node* node = find(key)) {
      if (!node->is_array()) throw type_error(key, "an array of strings");
      std::vector<std::string> values;
      for (const toml::node& element : *node->as_array()) {
        if (!element.is_string()) throw type_error(key, "an array of strings");
        values.push_back(element.as_string()->get());
      }
      out = std::move(values);
    }
  }
  // A sub-table, or nullptr if absent.
  const toml::table* table(const char* key) {
    const toml::node* node = find(key);
    if (!node) return nullptr;
    if (!node->is_table()) throw type_error(key, "a table");
    return node->as_table();
  }
  std::string name(const char* key) const { return prefix_.empty() ? key : prefix_ + "." + key; }

  // Throws naming the first key that no read() asked for.
  void reject_unknown() const {
    for (const auto& [key, node] : table_) {
      if (!seen_.count(std::string(key.str()))) {
        throw InvalidArgument(fmt::format("config '{}': unknown key '{}' (line {})", source_,
                                          name(std::string(key.str()).c_str()),
                                          node.source().begin.line));
      }
    }
  }

 private:
  const toml::node* find(const char* key) {
    seen_.insert(key);
    return table_.get(key);
  }
  InvalidArgument type_error(const char* key, const char* expected) const {
    return InvalidArgument(
        fmt::format("config '{}': key '{}' must be {}", source_, name(key), expected));
  }

  const toml::table& table_;
  std::string prefix_;
  const std::string& source_;
  std::set<std::string> seen_;
};

// TOML floats are doubles: write a float as the double with the same
// shortest text (0.03f -> 0.03, not 0.029999999329447746).
double float_for_toml(float f) { return std::strtod(fmt::format("{}", f).c_str(), nullptr); }

std::string method_name(GatherMethod method) {
  return method == GatherMethod::kFpbgi ? "fpbgi" : "pbgi";
}

GatherMethod parse_method(const std::string& name, const std::string& source) {
  if (name == "pbgi") return GatherMethod::kPbgi;
  if (name == "fpbgi") return GatherMethod::kFpbgi;
  throw InvalidArgument(fmt::format("config '{}': key 'gather.method' = '{}' is not pbgi or fpbgi",
                                    source, name));
}

SurfelSampler parse_sampler(const std::string& name, const std::string& source) {
  try {
    return parse_surfel_sampler(name);
  } catch (const InvalidArgument& e) {
    throw InvalidArgument(fmt::format("config '{}': key 'build.sampler': {}", source, e.what()));
  }
}

toml::array string_array(const std::vector<std::string>& values) {
  toml::array array;
  for (const std::string& v : values) array.push_back(v);
  return array;
}

uint32_t parse_unsigned(const char* variable, const char* text) {
  uint32_t value = 0;
  const char* end = text + std::strlen(text);
  auto [ptr, ec] = std::from_chars(text, end, value);
  if (ec != std::errc() || ptr != end) {
    throw InvalidArgument(fmt::format("environment {}='{}' is not an unsigned integer",
                                      variable, text));
  }
  return value;
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
  staging_quota_bytes();
  if (cache_dir.empty()) throw InvalidArgument("cache_dir is empty");
  if (memory_budget_bytes() < (1u << 20)) {
    throw InvalidArgument(fmt::format("memory_budget '{}' is below 1MiB", memory_budget));
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
  top.read("listen", out.listen);
  top.read("scene_roots", out.scene_roots);
  top.read("cache_dir", out.cache_dir);
  top.read("memory_budget", out.memory_budget);
  top.read("threads", out.threads);
  top.read("log_level", out.log_level);
  top.read("python", out.python);
  top.read("preload", out.preload);
  top.read("allow_insecure_remote", out.allow_insecure_remote);
  top.read("shutdown_grace_seconds", out.shutdown_grace_seconds);
  top.read("scene_memory_budget", out.scene_memory_budget);
  top.read("staging_quota", out.staging_quota);
  top.read("log_format", out.log_format);
  top.read("metrics_listen", out.metrics_listen);

  if (const toml::table* table = top.table("security")) {
    TableReader security(*table, "security", source);
    security.read("tls_cert", out.tls_cert);
    security.read("tls_key", out.tls_key);
    security.read("tls_client_ca", out.tls_client_ca);
    security.read("auth_token_file", out.auth_token_file);
    security.reject_unknown();
  }

  if (const toml::table* table = top.table("gather")) {
    TableReader gather(*table, "gather", source);
    RenderOptions& r = out.service.defaults.render;
    gather.read("microbuffer_resolution", r.gather.microbuffer_resolution);
    gather.read("max_solid_angle", r.gather.max_solid_angle);
    gather.read("ao_max_distance", r.gather.ao_max_distance);
    gather.read("light_samples", r.light_samples);
    gather.read("pixel_samples", r.pixel_samples);
    std::string method = method_name(r.gather.method);
    gather.read("method", method);
    r.gather.method = parse_method(method, source);
    gather.read("clusters", r.gather.clusters);
    gather.read("epsilon", r.gather.epsilon);
    gather.read("hdr_refine", r.gather.hdr_refine);
    gather.read("glossy_max_resolution", r.gather.glossy_max_resolution);
    gather.read("glossy_importance", r.gather.glossy_importance);
    gather.read("glossy_radiance_weight", r.gather.glossy_radiance_weight);
    gather.read("bent_normal", r.gather.bent_normal);
    std::string interpolation = interpolation_mode_name(r.interpolation.mode);
    gather.read("interpolation", interpolation);
    const std::optional<InterpolationMode> mode = parse_interpolation_mode(interpolation);
    if (!mode)
      throw InvalidArgument(
          fmt::format("{}: [gather] interpolation = \"{}\": expected \"off\" or \"auto\"", source, interpolation));
    r.interpolation.mode = *mode;
    gather.read("interpolation_tolerance", r.interpolation.tolerance);
    gather.read("interpolation_spacing", r.interpolation.spacing);
    gather.read("dome_visible", r.dome_visible);
    gather.reject_unknown();
  }
  if (const toml::table* table = top.table("build")) {
    TableReader build(*table, "build", source);
    OpenOptions& o = out.service.defaults.open;
    build.read("surfel_spacing", o.surfels.spacing);
    std::string sampler = to_string(o.surfels.sampler);
    build.read("sampler", sampler);
    o.surfels.sampler = parse_sampler(sampler, source);
    build.read("spacing_camera", o.surfels.camera);
    build.read("spacing_image_width", o.surfels.image_width);
    build.read("spacing_image_height", o.surfels.image_height);
    build.read("pixel_footprint", o.surfels.pixel_footprint);
    build.read("glossy_roughness", o.surfels.glossy_roughness);
    build.read("glossy_resolution", o.tree.glossy_resolution);
    build.read("wavelet_threshold", o.tree.wavelet_threshold);
    build.read("target_surfels", o.surfels.target_surfels);
    build.read("light_samples", o.surfels.light_samples);
    build.read("seed", o.surfels.seed);
    build.read("page_size", o.tree.page_size);
    build.read("leaf_size", o.tree.leaf_size);
    std::string leaf_format = storage::to_string(o.tree.leaf_format);
    build.read("leaf_format", leaf_format);
    o.tree.leaf_format = storage::parse_leaf_format(leaf_format);
    std::string payload_codec = tree::to_string(o.tree.payload_codec);
    build.read("payload_codec", payload_codec);
    o.tree.payload_codec = tree::parse_payload_codec(payload_codec);
    build.read("lut_entries", o.tree.lut_entries);
    build.read("lut_sample_fraction", o.tree.lut_sample_fraction);
    build.read("bounces", o.bounce.bounces);
    build.read("bounce_splatting", o.bounce.splatting);
    build.read("bounce_view_solid_angle", o.bounce.view_solid_angle);
    build.read("default_light", o.default_light);
    build.read("bounce_receiver_stride", o.bounce.receiver_stride);
    build.read("bounce_microbuffer_resolution", o.bounce.gather.microbuffer_resolution);
    build.read("bounce_max_solid_angle", o.bounce.gather.max_solid_angle);
    build.reject_unknown();
  }
  if (const toml::table* table = top.table("fog")) {
    TableReader fog(*table, "fog", source);
    FogOptions& f = out.service.defaults.open.fog;
    fog.read("extinction_per_density", f.extinction_per_density);
    float albedo = f.albedo.x;  // grey: one value for r, g, b
    fog.read("albedo", albedo);
    f.albedo = Imath::C3f(albedo);
    fog.read("step_voxels", f.step_voxels);
    fog.read("light_samples", f.light_samples);
    fog.read("max_block_voxels", f.max_block_voxels);
    fog.reject_unknown();
    f.validate();
  }
  if (const toml::table* table = top.table("limits")) {
    TableReader limits(*table, "limits", source);
    service::RequestLimits& l = out.service.limits;
    limits.read("max_receivers", l.max_receivers);
    limits.read("max_image_side", l.max_image_side);
    limits.read("max_tile_pixels", l.max_tile_pixels);
    limits.read("max_message_size", out.max_message_size);
    limits.read("max_tiles_per_call", l.max_tiles_per_call);
    limits.read("max_in_flight", l.max_in_flight);
    limits.read("max_queued", l.max_queued);
    limits.read("max_surfels", l.max_surfels);
    limits.reject_unknown();
  }
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
  // Written by hand rather than through toml++'s formatter, which prints
  // floats with 17 digits (0.029999999999999999) or only 6: here a float
  // prints as the shortest text that reads back to the same float.
  std::ostringstream out;
  auto string_value = [&](const char* key, const std::string& v) {
    out << key << " = " << toml::value<std::string>(v) << '\n';
  };
  auto strings_value = [&](const char* key, const std::vector<std::string>& v) {
    out << key << " = " << string_array(v) << '\n';
  };
  auto integer_value = [&](const char* key, uint64_t v) { out << key << " = " << v << '\n'; };
  auto float_value = [&](const char* key, double v) {
    std::string text = fmt::format("{}", v);
    if (text.find_first_of(".eEn") == std::string::npos) text += ".0";  // TOML float syntax
    out << key << " = " << text << '\n';
  };
  auto float32_value = [&](const char* key, float v) { float_value(key, float_for_toml(v)); };
  auto bool_value = [&](const char* key, bool v) { out << key << " = " << (v ? "true" : "false") << '\n'; };

  out << "# pbgid effective configuration\n";
  string_value("listen", o.effective_listen());
  strings_value("scene_roots", o.scene_roots);
  string_value("cache_dir", o.cache_dir);
  string_value("memory_budget", o.memory_budget);
  integer_value("threads", o.threads);
  string_value("log_level", o.log_level);
  string_value("python", o.python);
  strings_value("preload", o.preload);
  out << "allow_insecure_remote = " << (o.allow_insecure_remote ? "true" : "false") << '\n';
  float_value("shutdown_grace_seconds", o.shutdown_grace_seconds);
  string_value("scene_memory_budget", o.scene_memory_budget);
  string_value("staging_quota", o.staging_quota);
  string_value("log_format", o.log_format);
  string_value("metrics_listen", o.metrics_listen);

  const RenderOptions& r = o.service.defaults.render;
  out << "\n[gather]\n";
  integer_value("microbuffer_resolution", r.gather.microbuffer_resolution);
  float32_value("max_solid_angle", r.gather.max_solid_angle);
  float32_value("ao_max_distance", r.gather.ao_max_distance);
  integer_value("light_samples", r.light_samples);
  integer_value("pixel_samples", r.pixel_samples);
  string_value("method", method_name(r.gather.method));
  integer_value("clusters", r.gather.clusters);
  float32_value("epsilon", r.gather.epsilon);
  float32_value("hdr_refine", r.gather.hdr_refine);
  integer_value("glossy_max_resolution", r.gather.glossy_max_resolution);
  float32_value("glossy_importance", r.gather.glossy_importance);
  float32_value("glossy_radiance_weight", r.gather.glossy_radiance_weight);
  bool_value("bent_normal", r.gather.bent_normal);
  string_value("interpolation", interpolation_mode_name(r.interpolation.mode));
  float32_value("interpolation_tolerance", r.interpolation.tolerance);
  integer_value("interpolation_spacing", r.interpolation.spacing);
  bool_value("dome_visible", r.dome_visible);

  const OpenOptions& b = o.service.defaults.open;
  out << "\n[build]\n";
  float32_value("surfel_spacing", b.surfels.spacing);
  string_value("sampler", to_string(b.surfels.sampler));
  string_value("spacing_camera", b.surfels.camera);
  integer_value("spacing_image_width", b.surfels.image_width);
  integer_value("spacing_image_height", b.surfels.image_height);
  float32_value("pixel_footprint", b.surfels.pixel_footprint);
  float32_value("glossy_roughness", b.surfels.glossy_roughness);
  integer_value("glossy_resolution", b.tree.glossy_resolution);
  float32_value("wavelet_threshold", b.tree.wavelet_threshold);
  integer_value("target_surfels", b.surfels.target_surfels);
  integer_value("light_samples", b.surfels.light_samples);
  integer_value("seed", b.surfels.seed);
  integer_value("page_size", b.tree.page_size);
  integer_value("leaf_size", b.tree.leaf_size);
  string_value("leaf_format", storage::to_string(b.tree.leaf_format));
  string_value("payload_codec", tree::to_string(b.tree.payload_codec));
  integer_value("lut_entries", b.tree.lut_entries);
  float_value("lut_sample_fraction", b.tree.lut_sample_fraction);
  integer_value("bounces", b.bounce.bounces);
  out << "bounce_splatting = " << (b.bounce.splatting ? "true" : "false") << '\n';
  float32_value("bounce_view_solid_angle", b.bounce.view_solid_angle);
  bool_value("default_light", b.default_light);
  integer_value("bounce_receiver_stride", b.bounce.receiver_stride);
  integer_value("bounce_microbuffer_resolution", b.bounce.gather.microbuffer_resolution);
  float32_value("bounce_max_solid_angle", b.bounce.gather.max_solid_angle);

  out << "\n[fog]\n";
  float32_value("extinction_per_density", b.fog.extinction_per_density);
  float32_value("albedo", b.fog.albedo.x);
  float32_value("step_voxels", b.fog.step_voxels);
  integer_value("light_samples", b.fog.light_samples);
  integer_value("max_block_voxels", b.fog.max_block_voxels);

  const service::RequestLimits& l = o.service.limits;
  out << "\n[limits]\n";
  integer_value("max_receivers", l.max_receivers);
  integer_value("max_image_side", l.max_image_side);
  integer_value("max_tile_pixels", l.max_tile_pixels);
  string_value("max_message_size", o.max_message_size);
  integer_value("max_tiles_per_call", l.max_tiles_per_call);
  integer_value("max_in_flight", l.max_in_flight);
  integer_value("max_queued", l.max_queued);
  integer_value("max_surfels", l.max_surfels);

  out << "\n[security]\n";
  string_value("tls_cert", o.tls_cert);
  string_value("tls_key", o.tls_key);
  string_value("tls_client_ca", o.tls_client_ca);
  string_value("auth_token_file", o.auth_token_file);
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
  if (const char* v = get("PBGI_LISTEN")) o.listen = v;
  if (const char* v = get("PBGI_SCENE_ROOTS")) {
    o.scene_roots.clear();
    std::string_view rest(v);
    while (!rest.empty()) {
      const size_t colon = rest.find(':');
      std::string_view item = rest.substr(0, colon);
      if (!item.empty()) o.scene_roots.emplace_back(item);
      rest = colon == std::string_view::npos ? std::string_view() : rest.substr(colon + 1);
    }
  }
  if (const char* v = get("PBGI_CACHE_DIR")) o.cache_dir = v;
  if (const char* v = get("PBGI_MEMORY_BUDGET")) {
    parse_byte_size(v, "environment PBGI_MEMORY_BUDGET");  // fail here, naming the variable
    o.memory_budget = v;
  }
  if (const char* v = get("PBGI_THREADS")) o.threads = parse_unsigned("PBGI_THREADS", v);
  if (const char* v = get("PBGI_LOG_LEVEL")) o.log_level = v;
  if (const char* v = get("PBGI_PYTHON")) o.python = v;
  if (const char* v = get("PBGI_AUTH_TOKEN")) o.auth_token = v;
  if (const char* v = get("PBGI_AUTH_TOKEN_FILE")) o.auth_token_file = v;
  if (const char* v = get("PBGI_METRICS_LISTEN")) o.metrics_listen = v;
}

bool operator==(const DaemonOptions& a, const DaemonOptions& b) {
  const RenderOptions &ra = a.service.defaults.render, &rb = b.service.defaults.render;
  const OpenOptions &oa = a.service.defaults.open, &ob = b.service.defaults.open;
  const service::RequestLimits &la = a.service.limits, &lb = b.service.limits;
  return a.effective_listen() == b.effective_listen() && a.scene_roots == b.scene_roots &&
         a.cache_dir == b.cache_dir && a.memory_budget == b.memory_budget &&
         a.threads == b.threads && a.log_level == b.log_level && a.python == b.python &&
         a.preload == b.preload && a.allow_insecure_remote == b.allow_insecure_remote &&
         a.shutdown_grace_seconds == b.shutdown_grace_seconds &&
         a.max_message_size == b.max_message_size &&
         a.scene_memory_budget == b.scene_memory_budget && a.staging_quota == b.staging_quota &&
         a.log_format == b.log_format && la.max_surfels == lb.max_surfels &&
         a.metrics_listen == b.metrics_listen && a.tls_cert == b.tls_cert &&
         a.tls_key == b.tls_key && a.tls_client_ca == b.tls_client_ca &&
         a.auth_token_file == b.auth_token_file && a.auth_token == b.auth_token &&
         la.max_tiles_per_call == lb.max_tiles_per_call &&
         la.max_in_flight == lb.max_in_flight && la.max_queued == lb.max_queued &&
         ra.gather.microbuffer_resolution == rb.gather.microbuffer_resolution &&
         ra.gather.max_solid_angle == rb.gather.max_solid_angle &&
         ra.gather.ao_max_distance == rb.gather.ao_max_distance &&
         ra.light_samples == rb.light_samples && ra.pixel_samples == rb.pixel_samples &&
         ra.gather.method == rb.gather.method && ra.gather.clusters == rb.gather.clusters &&
         ra.gather.epsilon == rb.gather.epsilon && ra.gather.hdr_refine == rb.gather.hdr_refine &&
         ra.gather.glossy_max_resolution == rb.gather.glossy_max_resolution &&
         ra.gather.glossy_importance == rb.gather.glossy_importance &&
         ra.gather.glossy_radiance_weight == rb.gather.glossy_radiance_weight &&
         ra.gather.bent_normal == rb.gather.bent_normal &&
         ra.interpolation.mode == rb.interpolation.mode &&
         ra.interpolation.tolerance == rb.interpolation.tolerance &&
         ra.interpolation.spacing == rb.interpolation.spacing &&
         ra.gather.bent_normal == rb.gather.bent_normal && ra.dome_visible == rb.dome_visible &&
         oa.default_light == ob.default_light &&
         oa.surfels.spacing == ob.surfels.spacing && oa.surfels.sampler == ob.surfels.sampler &&
         oa.surfels.camera == ob.surfels.camera && oa.surfels.image_width == ob.surfels.image_width &&
         oa.surfels.image_height == ob.surfels.image_height &&
         oa.surfels.pixel_footprint == ob.surfels.pixel_footprint &&
         oa.surfels.glossy_roughness == ob.surfels.glossy_roughness &&
         oa.tree.glossy_resolution == ob.tree.glossy_resolution &&
         oa.tree.wavelet_threshold == ob.tree.wavelet_threshold &&
         oa.surfels.target_surfels == ob.surfels.target_surfels &&
         oa.surfels.light_samples == ob.surfels.light_samples &&
         oa.surfels.seed == ob.surfels.seed && oa.tree.page_size == ob.tree.page_size &&
         oa.tree.leaf_size == ob.tree.leaf_size && oa.tree.leaf_format == ob.tree.leaf_format &&
         oa.tree.payload_codec == ob.tree.payload_codec &&
         oa.tree.lut_entries == ob.tree.lut_entries &&
         oa.tree.lut_sample_fraction == ob.tree.lut_sample_fraction &&
         oa.bounce.bounces == ob.bounce.bounces && oa.bounce.splatting == ob.bounce.splatting &&
         oa.bounce.view_solid_angle == ob.bounce.view_solid_angle &&
         oa.bounce.receiver_stride == ob.bounce.receiver_stride &&
         oa.bounce.gather.microbuffer_resolution == ob.bounce.gather.microbuffer_resolution &&
         oa.bounce.gather.max_solid_angle == ob.bounce.gather.max_solid_angle && oa.fog.extinction_per_density == ob.fog.extinction_per_density &&
         oa.fog.albedo == ob.fog.albedo && oa.fog.step_voxels == ob.fog.step_voxels &&
         oa.fog.light_samples == ob.fog.light_samples && oa.fog.max_block_voxels == ob.fog.max_block_voxels &&
         la.max_receivers == lb.max_receivers &&
         la.max_image_side == lb.max_image_side && la.max_tile_pixels == lb.max_tile_pixels;
}

}  // namespace pbgi::daemon
