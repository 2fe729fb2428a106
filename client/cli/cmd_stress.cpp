// `pbgi stress`: concurrent clients rendering random tiles through one or
// more daemons for a fixed time; prints throughput, latency percentiles and
// errors by status code, optionally samples the daemon's RSS into a CSV.
// Exit status: 0 = no error (and RSS within --max-rss), 1 = errors during
// the load or RSS over the limit, 2 = the run could not start.
#include "client/cli/build_flags.h"
#include "client/cli/command.h"
#include "client/cli/gather_flags.h"
#include "client/stress/rss_sampler.h"
#include "client/stress/stress_report.h"
#include "client/stress/stress_runner.h"
#include "common/byte_size.h"
#include "common/errors.h"

#include <fmt/format.h>

#include <cstdio>
#include <cstdlib>
#include <memory>
#include <optional>

namespace pbgi::cli {
namespace {

struct StressArgs {
  std::vector<std::string> servers;
  std::string scene, camera;
  unsigned clients = 4;
  std::string duration = "10s";
  std::string image = "256x256";
  uint32_t tile = 32;
  bool json = false;
  bool quiet = false;
  int daemon_pid = 0;
  std::string rss_csv;
  double rss_interval = 0.5;   // seconds
  std::string max_rss;         // "" = no limit
  double deadline = 60;        // seconds per RenderTile
  int attempts = 1;
  uint64_t seed = 1;
  // OpenScene's build and RenderTile's gather options: the flags of
  // `pbgi render` (build_flags.h, gather_flags.h).
  BuildArgs build;
  GatherArgs gather;
};

// "30", "30s", "1.5m", "2h" -> seconds.
double parse_duration(const std::string& text) {
  size_t used = 0;
  double v = 0;
  try {
    v = std::stod(text, &used);
  } catch (const std::exception&) {
    throw InvalidArgument(fmt::format("--duration '{}' is not a duration (e.g. 30s, 10m)", text));
  }
  const std::string unit = text.substr(used);
  double scale = 0;
  if (unit.empty() || unit == "s") scale = 1;
  else if (unit == "ms") scale = 1e-3;
  else if (unit == "m" || unit == "min") scale = 60;
  else if (unit == "h") scale = 3600;
  if (scale == 0 || !(v > 0)) {
    throw InvalidArgument(fmt::format("--duration '{}' is not a positive duration (e.g. 30s, 10m)", text));
  }
  return v * scale;
}

// "256x128" -> (256, 128).
std::pair<uint32_t, uint32_t> parse_image(const std::string& text) {
  unsigned w = 0, h = 0;
  char x = 0, extra = 0;
  if (std::sscanf(text.c_str(), "%u%c%u%c", &w, &x, &h, &extra) != 3 || (x != 'x' && x != 'X') ||
      w == 0 || h == 0) {
    throw InvalidArgument(fmt::format("--image '{}' is not WIDTHxHEIGHT", text));
  }
  return {w, h};
}

int run(const StressArgs& a) {
  stress::StressOptions options;
  options.servers = a.servers;
  options.scene = a.scene;
  options.camera = a.camera;
  options.clients = a.clients;
  options.duration = std::chrono::duration<double>(parse_duration(a.duration));
  std::tie(options.width, options.height) = parse_image(a.image);
  options.tile = a.tile;
  options.call_deadline = std::chrono::milliseconds(static_cast<int64_t>(a.deadline * 1000));
  options.max_attempts = a.attempts;
  options.seed = a.seed;
  options.build = a.build.to_proto(options.width, options.height);
  options.gather = a.gather.to_proto();
  const uint64_t max_rss = a.max_rss.empty() ? 0 : parse_byte_size(a.max_rss, "--max-rss");
  if (a.daemon_pid <= 0 && (max_rss || !a.rss_csv.empty())) {
    throw InvalidArgument("--max-rss and --rss-csv need --daemon-pid");
  }

  // The sampler starts before the scene is opened so that the curve shows
  // the open as well as the load.
  std::unique_ptr<stress::RssSampler> sampler;
  if (a.daemon_pid > 0) {
    sampler = std::make_unique<stress::RssSampler>(
        a.daemon_pid, std::chrono::milliseconds(static_cast<int64_t>(a.rss_interval * 1000)));
  }
  auto progress = [&](double t, uint64_t requests, uint64_t errors) {
    if (a.quiet) return;
    std::string rss;
    if (sampler) {
      const auto s = sampler->samples();
      rss = fmt::format("  rss {:.0f} MiB", s.back().rss_bytes / (1024.0 * 1024.0));
    }
    std::fprintf(stderr, "stress: %6.1fs  %llu requests  %llu errors%s\n", t,
                 static_cast<unsigned long long>(requests),
                 static_cast<unsigned long long>(errors), rss.c_str());
  };
  const stress::StressResult result = stress::run_stress(options, progress);
  std::optional<stress::RssSummary> rss;
  if (sampler) {
    sampler->stop();
    const auto samples = sampler->samples();
    if (!a.rss_csv.empty()) stress::write_rss_csv(samples, a.rss_csv);
    rss = stress::summarize_rss(samples, max_rss, a.rss_csv);
  }
  const std::string report =
      a.json ? stress::format_stress_json(result, rss) : stress::format_stress_text(result, rss);
  std::fputs(report.c_str(), stdout);
  std::fflush(stdout);
  return result.passed() && (!rss || rss->within_limit()) ? 0 : 1;
}

const CommandRegistrar registrar("stress", [](CLI::App& app, int* exit_code) {
  auto args = std::make_shared<StressArgs>();
  CLI::App* cmd = app.add_subcommand(
      "stress", "Load a daemon with concurrent random-tile requests and report latency and errors");
  cmd->add_option("--server", args->servers,
                  "Daemon address (unix:PATH or HOST:PORT); repeat for replicas (round robin)")
      ->required();
  cmd->add_option("--scene", args->scene, "Scene to open (path as the daemon resolves it)")->required();
  cmd->add_option("--camera,-c", args->camera, "Camera prim (default: the scene's only camera)");
  cmd->add_option("--clients", args->clients, "Concurrent clients")->check(CLI::Range(1u, 4096u));
  cmd->add_option("--duration", args->duration, "Length of the load: 30s, 10m, 1h");
  cmd->add_option("--image", args->image, "Image size WxH the random tiles are cut from");
  cmd->add_option("--tile", args->tile, "Tile side in pixels")->check(CLI::Range(1u, 4096u));
  cmd->add_flag("--json", args->json, "Print the report as JSON");
  cmd->add_flag("-q,--quiet", args->quiet, "No progress lines on stderr");
  cmd->add_option("--daemon-pid", args->daemon_pid, "Sample this process's RSS (/proc/PID/status)");
  cmd->add_option("--rss-csv", args->rss_csv, "Write the RSS curve here (seconds,rss_mib)");
  cmd->add_option("--rss-interval", args->rss_interval, "Seconds between RSS samples")
      ->check(CLI::Range(0.01, 3600.0));
  cmd->add_option("--max-rss", args->max_rss, "Fail if the daemon's RSS exceeds this (e.g. 1GiB)");
  cmd->add_option("--deadline", args->deadline, "Seconds per RenderTile call")
      ->check(CLI::Range(0.001, 86400.0));
  cmd->add_option("--attempts", args->attempts, "Attempts per call on UNAVAILABLE (1 = no retry)")
      ->check(CLI::Range(1, 100));
  cmd->add_option("--seed", args->seed, "Seed of the random tile choice");
  args->gather.add_to(cmd);
  args->build.add_to(cmd);
  cmd->callback([args, exit_code] {
    try {
      *exit_code = run(*args);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "pbgi stress: %s\n", e.what());
      *exit_code = 2;
    }
  });
});

}  // namespace
}  // namespace pbgi::cli
