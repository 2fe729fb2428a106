// Everything pbgid can be configured with, in one struct. The layers, later
// ones winning: the defaults below, a TOML file (--config or PBGI_CONFIG),
// PBGI_* environment variables, command-line flags (daemon_command_line.h).
//
// TOML layout (config/pbgid.toml is a commented example):
//   listen, scene_roots, cache_dir, memory_budget, request_memory,
//   page_cache_floor, scene_memory_budget,
//   staging_quota, threads, log_level, log_format, python, preload,
//   allow_insecure_remote, shutdown_grace_seconds, metrics_listen
//   [security] tls_cert, tls_key, tls_client_ca, auth_token_file
//   [gather]  microbuffer_resolution, max_solid_angle, ao_max_distance,
//             light_samples, pixel_samples, method ("pbgi" | "fpbgi"),
//             clusters, epsilon, hdr_refine           (request defaults)
//   [build]   surfel_spacing, target_surfels, light_samples, page_size,
//             leaf_size, seed, payload_codec, lut_entries,
//             lut_sample_fraction, bounces, bounce_splatting,
//             bounce_view_solid_angle, bounce_receiver_stride,
//             bounce_microbuffer_resolution,
//             bounce_max_solid_angle                  (OpenScene defaults)
//   [limits]  max_receivers, max_image_side, max_tile_pixels, max_message_size,
//             max_tiles_per_call, max_in_flight, max_queued, max_surfels
// Unknown keys are errors (a typo must not silently use a default).
#pragma once

#include "server/service/pbgi_service.h"

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

namespace pbgi::daemon {

struct DaemonOptions {
  // "unix:PATH" or "HOST:PORT"; "" = unix:<cache_dir>/pbgid.sock.
  std::string listen;
  // Directories scenes may be opened from (none: every OpenScene is refused).
  std::vector<std::string> scene_roots;
  // Page sets are built here (and the default socket lives here).
  std::string cache_dir = "./cache";
  // What the whole daemon may hold in memory, with K/M/G suffixes: the
  // request reserve (request_memory), every scene's geometry as it is read
  // (chunk by chunk), every open scene's geometry and ray-tracing
  // structure and every build's working memory (charged before they are
  // allocated, then measured), and the page cache, which gets
  // what remains (never less than page_cache_floor) and shrinks as scenes
  // come. A scene that cannot fit even with the idle scenes unloaded and
  // the cache at its floor is refused with RESOURCE_EXHAUSTED naming it
  // and the bytes it needs (server/engine/memory_accountant.h).
  // Not counted, the overhead (docs/memory-budget.md): code and
  // libraries, allocator slack, gRPC's and TBB's buffers and stacks, pages
  // gathers still hold after eviction, one stream frame and textures while
  // a scene is read; measured under 200 MiB of RSS above the budget.
  // GetStatus.memory and the pbgi_memory_* metrics say who holds what.
  std::string memory_budget = "2GiB";
  // The share of memory_budget kept for the requests in flight (their
  // messages, receivers and results; limits.max_in_flight bounds them).
  std::string request_memory = "64MiB";
  // The page cache is never shrunk below this to make room for scenes.
  std::string page_cache_floor = "32MiB";
  // The most the page cache holds, whatever memory_budget leaves it; "0" =
  // no cap (the cache takes what remains). For a cache of a known size
  // under a budget that also charges scenes (scripts/ooc_render.sh
  // CACHE_ONLY=1 measures the cache at fractions of a page set so).
  std::string page_cache_limit = "0";
  // TBB worker threads for gathers and renders; 0 = all cores.
  uint32_t threads = 0;
  // spdlog level: trace, debug, info, warn, error, critical, off.
  std::string log_level = "info";
  // Interpreter with usd-core for the USD reader; default: this build's venv.
  std::string python;
  // Scenes opened at start, before the daemon reports it is listening.
  std::vector<std::string> preload;
  // Allow plaintext TCP on a non-loopback address (TLS needs no permission).
  bool allow_insecure_remote = false;
  // A sub-limit within memory_budget on the open scenes alone (geometry +
  // ray structure, as charged to the budget): above it the least recently
  // used other scenes are unloaded after an open, even in use (requests
  // holding one finish); "0" = none (memory_budget alone, which unloads
  // only idle scenes and refuses what cannot fit).
  std::string scene_memory_budget = "0";
  // What the staging directories of all builds in progress may hold on
  // disk together (sort runs, pages being written), with K/M/G suffixes;
  // "0" = no limit. A build that would pass it stops with
  // RESOURCE_EXHAUSTED and removes what it staged. The default holds a
  // build of limits.max_surfels' default (200 M surfels: ~22 B per surfel
  // of compressed sort runs on the generated city, up to 96 B for surfels
  // that do not compress, and ~19 B per surfel of pages).
  std::string staging_quota = "32GiB";
  // "text" or "json" (one JSON object per line, for log collectors).
  std::string log_format = "text";
  // "HOST:PORT" of the Prometheus text endpoint (GET /metrics); "" = none.
  // With a bearer token /metrics needs it; off loopback one is required
  // unless allow_insecure_remote.
  std::string metrics_listen;
  // [security] PEM files. With tls_cert + tls_key the daemon speaks TLS;
  // with tls_client_ca as well it requires client certificates signed by it.
  std::string tls_cert, tls_key, tls_client_ca;
  // A file (mode 0600) holding the bearer token every call must carry.
  std::string auth_token_file;
  // The token itself, from PBGI_AUTH_TOKEN only (never written to a config
  // or printed); auth_token_file wins if both are set. PBGI_AUTH_TOKEN (or
  // PBGI_AUTH_TOKEN_FILE) set but empty is an error, not "no token".
  std::string auth_token;
  // On SIGTERM/SIGINT, in-flight requests (scene builds included) get this
  // long before they are cancelled; the daemon exits once they have
  // stopped (within a batch of work). A second signal exits at once.
  double shutdown_grace_seconds = 10.0;
  // Largest gRPC message accepted or sent (a 1M-receiver Gather is 24 MB).
  std::string max_message_size = "64MiB";
  // Request defaults ([gather], [build]) and limits ([limits]).
  service::ServiceOptions service;

  DaemonOptions();

  // The listen address with the default filled in.
  std::string effective_listen() const;
  uint64_t memory_budget_bytes() const;      // throws InvalidArgument
  uint64_t request_memory_bytes() const;     // throws InvalidArgument
  uint64_t page_cache_floor_bytes() const;   // throws InvalidArgument
  uint64_t page_cache_limit_bytes() const;   // throws InvalidArgument
  uint64_t max_message_bytes() const;        // throws InvalidArgument
  uint64_t scene_memory_budget_bytes() const;  // throws InvalidArgument
  uint64_t staging_quota_bytes() const;        // throws InvalidArgument
  bool tls() const { return !tls_cert.empty(); }
  // Checks every field; throws pbgi::InvalidArgument naming the key.
  void validate() const;
};

// Reads TOML text over `base`: keys present replace base's values, absent
// keys keep them. Throws pbgi::InvalidArgument naming `source` and the key
// (unknown key, wrong type, out of range) or the parse error's position.
DaemonOptions parse_daemon_config(std::string_view toml_text, const std::string& source,
                                  DaemonOptions base = {});
// The same for a file; throws IoError naming the file if it cannot be read.
DaemonOptions load_daemon_config(const std::filesystem::path& file, DaemonOptions base = {});

// The effective configuration as TOML that parse_daemon_config reads back
// to equal options.
std::string to_toml(const DaemonOptions& options);

// Reads an environment variable (nullptr = unset); injectable for tests.
using Environment = std::function<const char*(const char* name)>;
Environment process_environment();

// Applies the PBGI_* variables of daemon_settings.h's table (PBGI_LISTEN,
// PBGI_SCENE_ROOTS (':'-separated), PBGI_CACHE_DIR, PBGI_MEMORY_BUDGET,
// PBGI_THREADS, PBGI_LOG_LEVEL, PBGI_PYTHON, PBGI_AUTH_TOKEN,
// PBGI_AUTH_TOKEN_FILE, PBGI_METRICS_LISTEN). Throws InvalidArgument
// naming the variable for a malformed value.
void apply_environment(DaemonOptions& options, const Environment& env);

bool operator==(const DaemonOptions& a, const DaemonOptions& b);

}  // namespace pbgi::daemon
