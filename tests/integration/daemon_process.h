// pbgid as a child process for the integration tests: started with a
// fresh cache dir and socket under a temporary directory, ready once it
// prints "pbgid listening on", stopped with SIGTERM like a service manager.
#pragma once

#include <chrono>
#include <filesystem>
#include <string>
#include <vector>

#include <sys/types.h>

namespace pbgi::testing {

// Runs `argv` (argv[0] = executable path) with stdout and stderr going to
// the given files; returns the child's pid. Throws std::runtime_error.
pid_t spawn(const std::vector<std::string>& argv, const std::filesystem::path& out_file,
            const std::filesystem::path& err_file);

// Waits up to `timeout` for the child to exit; returns its exit status
// (128 + signal if killed), or -1 on timeout (the child is left running).
int wait_for_exit(pid_t pid, std::chrono::milliseconds timeout);

class DaemonProcess {
 public:
  // Starts `binary` with --listen unix:<tmp>/pbgid.sock --cache-dir <tmp>/cache
  // and `extra_args`; waits up to `timeout` for readiness. Throws
  // std::runtime_error with the daemon's log if it exits or times out.
  DaemonProcess(const std::filesystem::path& binary, const std::vector<std::string>& extra_args,
                std::chrono::milliseconds timeout = std::chrono::seconds(60));
  ~DaemonProcess();   // SIGKILL if still running; removes the temporary directory

  const std::string& address() const { return address_; }
  const std::filesystem::path& socket_path() const { return socket_path_; }
  const std::filesystem::path& dir() const { return dir_; }
  std::string log() const;   // stdout + stderr so far

  // SIGTERM, then waits for the exit; returns the exit status (-1: timeout).
  int terminate(std::chrono::milliseconds timeout = std::chrono::seconds(30));

 private:
  std::filesystem::path dir_, socket_path_;
  std::string address_;
  pid_t pid_ = -1;
};

}  // namespace pbgi::testing
