// What the reliability tests share: where the binaries and the test scene
// are, small build and gather options (the whole folder must run in well
// under two minutes on two cores), and launching a daemon in a test's
// temporary directory.
#pragma once

#include "client/lib/frame_renderer.h"
#include "client/lib/pbgi_client.h"
#include "tests/support/daemon_process.h"

#include <gtest/gtest.h>

#include <sys/wait.h>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace pbgi::testing {

inline const std::filesystem::path kSourceDir = PBGI_TEST_SOURCE_DIR;
inline const std::filesystem::path kBinaryDir = PBGI_TEST_BINARY_DIR;
inline const std::filesystem::path kPbgid = kBinaryDir / "bin" / "pbgid";
inline const std::filesystem::path kPbgi = kBinaryDir / "bin" / "pbgi";
inline const std::filesystem::path kScenes = kSourceDir / "scenes";
inline const std::filesystem::path kCornell = kScenes / "cornell.usda";

inline v1::BuildOptions build_with(uint64_t target_surfels) {
  v1::BuildOptions b;
  b.set_target_surfels(target_surfels);
  b.set_light_samples(4);
  return b;
}

// One attempt per call: a test sees the daemon's answer, not a retry's.
inline client::ClientOptions no_retry() {
  client::ClientOptions o;
  o.max_attempts = 1;
  return o;
}

inline v1::GatherOptions fast_gather() {
  v1::GatherOptions o;
  o.set_light_samples(4);
  return o;
}

// A daemon on `cache` listening on <tmp>/<name>.sock, logging to <tmp>/<name>/.
inline std::unique_ptr<DaemonInstance> start_daemon(const TempDir& tmp, const std::string& name,
                                                    const std::filesystem::path& cache,
                                                    uint64_t file_size_limit = 0,
                                                    std::vector<std::string> extra = {}) {
  DaemonLaunch launch;
  launch.binary = kPbgid;
  launch.cache_dir = cache;
  launch.socket = tmp / (name + ".sock");
  launch.log_dir = tmp / name;
  launch.extra_args = {"--scene-root", kScenes.string(), "--log-level", "info",
                       "--memory-budget", "256MiB"};
  launch.extra_args.insert(launch.extra_args.end(), extra.begin(), extra.end());
  launch.file_size_limit = file_size_limit;
  return std::make_unique<DaemonInstance>(launch);
}

inline client::FrameRequest frame_request(const std::string& scene_id, uint32_t size = 32,
                                          uint32_t tile = 8) {
  client::FrameRequest r;
  r.scene_id = scene_id;
  r.camera = "/Camera";
  r.width = size;
  r.height = size;
  r.tile_size = tile;
  r.jobs = 4;
  r.options = fast_gather();
  return r;
}

// Bitwise equality of every AOV: the same page set and options must give
// the same pixels whichever daemon renders them.
inline ::testing::AssertionResult frames_identical(const client::Frame& a, const client::Frame& b) {
  if (a.width != b.width || a.height != b.height) {
    return ::testing::AssertionFailure() << "sizes differ";
  }
  const std::pair<const char*, std::pair<const std::vector<float>*, const std::vector<float>*>> aovs[] = {
      {"beauty", {&a.beauty, &b.beauty}},       {"direct", {&a.direct, &b.direct}},
      {"indirect", {&a.indirect, &b.indirect}}, {"albedo", {&a.albedo, &b.albedo}},
      {"ao", {&a.ao, &b.ao}}};
  for (const auto& [name, pair] : aovs) {
    const auto& [x, y] = pair;
    if (x->size() != y->size()) return ::testing::AssertionFailure() << name << ": sizes differ";
    for (size_t i = 0; i < x->size(); ++i) {
      if (std::memcmp(&(*x)[i], &(*y)[i], sizeof(float)) != 0) {
        return ::testing::AssertionFailure()
               << name << "[" << i << "]: " << (*x)[i] << " vs " << (*y)[i];
      }
    }
  }
  return ::testing::AssertionSuccess();
}

// Page-set directories (those holding a manifest) directly in `cache`.
inline std::vector<std::filesystem::path> published_page_sets(const std::filesystem::path& cache) {
  std::vector<std::filesystem::path> out;
  if (!std::filesystem::exists(cache)) return out;
  for (const auto& e : std::filesystem::directory_iterator(cache)) {
    if (e.is_directory() && std::filesystem::exists(e.path() / "manifest.pbgm")) out.push_back(e.path());
  }
  return out;
}

// Entries of `cache` whose name contains `part` (".tmp-", ".corrupt-").
inline std::vector<std::filesystem::path> entries_named(const std::filesystem::path& cache,
                                                        const std::string& part) {
  std::vector<std::filesystem::path> out;
  if (!std::filesystem::exists(cache)) return out;
  for (const auto& e : std::filesystem::directory_iterator(cache)) {
    if (e.path().filename().string().find(part) != std::string::npos) out.push_back(e.path());
  }
  return out;
}

// Runs a shell command line; returns its exit status and stdout.
struct CommandResult {
  int status = -1;
  std::string out;
};
inline CommandResult run_command(const std::string& command_line) {
  CommandResult r;
  FILE* pipe = popen(command_line.c_str(), "r");
  if (!pipe) return r;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, pipe)) > 0) r.out.append(buf, n);
  const int status = pclose(pipe);
  r.status = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  return r;
}

}  // namespace pbgi::testing
