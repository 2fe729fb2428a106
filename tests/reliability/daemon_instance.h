// pbgid as a child process for fault injection: unlike the integration
// tests' DaemonProcess, the cache directory and socket are given by the
// test (so that a daemon can be killed and another started on the same
// page sets, or two run side by side), the pid is exposed (kill -9, RSS,
// CPU time), and resource limits can be set in the child before exec.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace pbgi::testing {

struct DaemonLaunch {
  std::filesystem::path binary;       // pbgid
  std::filesystem::path cache_dir;
  std::filesystem::path socket;       // listens on unix:<socket>
  std::filesystem::path log_dir;      // stdout.log / stderr.log go here
  std::vector<std::string> extra_args;
  uint64_t file_size_limit = 0;       // RLIMIT_FSIZE in bytes; 0 = unlimited
  std::chrono::milliseconds ready_timeout{60000};
};

class DaemonInstance {
 public:
  // Starts the daemon and waits until it reports "pbgid listening on".
  // Throws std::runtime_error with its log if it exits or times out.
  explicit DaemonInstance(DaemonLaunch launch);
  ~DaemonInstance();   // SIGKILL if still running
  DaemonInstance(const DaemonInstance&) = delete;
  DaemonInstance& operator=(const DaemonInstance&) = delete;

  pid_t pid() const { return pid_; }
  std::string address() const { return "unix:" + launch_.socket.string(); }
  std::string log() const;     // stdout + stderr so far
  std::string stderr_log() const;

  // kill -9 and reap; returns the exit status (128 + 9).
  int kill9();
  // SIGTERM, then waits; returns the exit status (-1: timeout).
  int terminate(std::chrono::milliseconds timeout = std::chrono::seconds(30));
  bool running() const { return pid_ > 0; }

 private:
  DaemonLaunch launch_;
  pid_t pid_ = -1;
};

// CPU time (user + system) a process has used so far, from /proc/PID/stat.
double process_cpu_seconds(pid_t pid);

// A fresh directory under /tmp, removed by the destructor.
class TempDir {
 public:
  explicit TempDir(const std::string& prefix = "pbgi-rel");
  ~TempDir();
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& name) const { return path_ / name; }

 private:
  std::filesystem::path path_;
};

}  // namespace pbgi::testing
