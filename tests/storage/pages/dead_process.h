// A process id that is certainly dead, for the tests of cleaning up after
// crashed processes: a child that has exited and been reaped.
#pragma once

#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <stdexcept>

namespace pbgi::testing {

inline pid_t dead_process_id() {
  const pid_t pid = fork();
  if (pid == 0) _exit(0);
  if (pid < 0) throw std::runtime_error("fork failed");
  waitpid(pid, nullptr, 0);
  return pid;
}

}  // namespace pbgi::testing
