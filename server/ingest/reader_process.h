// A child process (the USD reader) with its stdout and stderr on pipes.
// stdout is handed to the caller to decode; stderr is drained by a thread
// and its last bytes are kept for error messages.
//
// Not thread-safe: one owner drives a ReaderProcess. The destructor kills
// (SIGKILL) and reaps a child that is still running, so no zombie or stray
// reader outlives its owner.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace pbgi {

class ReaderProcess {
 public:
  // How the child ended.
  struct Exit {
    bool signaled = false;  // killed by a signal (ours or another)
    int code = 0;           // exit code, or the signal number if signaled
    bool killed_by_us = false;
  };

  // Starts argv[0] (searched in PATH if it has no slash) with `environment`
  // ("NAME=value" strings) and stdin on /dev/null. Throws IoError naming the
  // program if it cannot be started.
  ReaderProcess(const std::vector<std::string>& argv, const std::vector<std::string>& environment,
                size_t stderr_tail_bytes = 4096);
  ~ReaderProcess();
  ReaderProcess(const ReaderProcess&) = delete;
  ReaderProcess& operator=(const ReaderProcess&) = delete;

  int stdout_fd() const { return stdout_fd_; }
  // Closes our end of stdout: a child still writing gets EPIPE.
  void close_stdout();
  // Waits for the child; if it is still running after `grace`, kills it.
  // Also waits for stderr to be drained. Idempotent.
  Exit wait(std::chrono::milliseconds grace = std::chrono::milliseconds::max());
  // The last bytes the child wrote to stderr (complete after wait()).
  std::string stderr_tail() const;

 private:
  void drain_stderr();

  pid_t pid_ = -1;
  int stdout_fd_ = -1;
  int stderr_fd_ = -1;
  size_t tail_bytes_;
  mutable std::mutex tail_mutex_;
  std::string tail_;
  std::thread drainer_;
  bool waited_ = false;
  Exit exit_;
};

}  // namespace pbgi
