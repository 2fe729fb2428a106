// pbgid as a child process, for the integration and reliability tests (one
// implementation: the two folders had drifted copies).
//
//  - DaemonInstance: the cache directory, socket and log directory are given
//    by the test (a daemon can be killed and another started on the same
//    page sets, or two run side by side), the pid is exposed (kill -9, RSS,
//    CPU time), and resource limits can be set in the child before exec.
//  - DaemonProcess: a DaemonInstance in a fresh temporary directory of its
//    own (cache, socket, logs), removed when it goes.
// Both are ready once the socket exists and the daemon printed
// "pbgid listening on"; they throw std::runtime_error with the daemon's log
// if it exits first or is not ready in time.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace pbgi::testing {

// Runs `argv` (argv[0] = executable path) with stdout and stderr going to
// the given files; returns the child's pid. Throws std::runtime_error.
pid_t spawn(const std::vector<std::string>& argv, const std::filesystem::path& out_file,
            const std::filesystem::path& err_file);

// Waits up to `timeout` for the child to exit; returns its exit status
// (128 + signal if killed), or -1 on timeout (the child is left running).
int wait_for_exit(pid_t pid, std::chrono::milliseconds timeout);

struct DaemonLaunch {
  std::filesystem::path binary;  // pbgid
  std::filesystem::path cache_dir;
  std::filesystem::path socket;   // listens on unix:<socket>
  std::filesystem::path log_dir;  // stdout.log / stderr.log go here
  std::vector<std::string> extra_args;
  uint64_t file_size_limit = 0;  // RLIMIT_FSIZE in bytes; 0 = unlimited
  std::chrono::milliseconds ready_timeout{60000};
};

class DaemonInstance {
 public:
  // Starts the daemon and waits until it is ready (see above).
  explicit DaemonInstance(DaemonLaunch launch);
  ~DaemonInstance();  // SIGKILL if still running
  DaemonInstance(const DaemonInstance&) = delete;
  DaemonInstance& operator=(const DaemonInstance&) = delete;

  pid_t pid() const { return pid_; }
  std::string address() const { return "unix:" + launch_.socket.string(); }
  const std::filesystem::path& socket_path() const { return launch_.socket; }
  std::string log() const;  // stdout + stderr so far
  std::string stderr_log() const;

  // kill -9 and reap; returns the exit status (128 + 9).
  int kill9();
  // SIGTERM, then waits; returns the exit status (-1: timeout, the daemon
  // is left running; -3: not running).
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
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& name) const { return path_ / name; }

 private:
  std::filesystem::path path_;
};

class DaemonProcess {
 public:
  // Starts `binary` with --listen unix:<tmp>/pbgid.sock --cache-dir <tmp>/cache
  // and `extra_args`, logs in <tmp>; waits up to `timeout` for readiness.
  DaemonProcess(const std::filesystem::path& binary, const std::vector<std::string>& extra_args,
                std::chrono::milliseconds timeout = std::chrono::seconds(60));

  std::string address() const { return daemon_->address(); }
  const std::filesystem::path& socket_path() const { return daemon_->socket_path(); }
  const std::filesystem::path& dir() const { return dir_.path(); }
  std::string log() const { return daemon_->log(); }
  int terminate(std::chrono::milliseconds timeout = std::chrono::seconds(30)) { return daemon_->terminate(timeout); }

 private:
  TempDir dir_;  // destroyed last: the daemon has exited by then
  std::optional<DaemonInstance> daemon_;
};

}  // namespace pbgi::testing
