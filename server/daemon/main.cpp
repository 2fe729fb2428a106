// pbgid: the PBGI daemon. Thin: parse the command line, start the Daemon,
// wait for SIGTERM/SIGINT, drain.
#include "server/daemon/daemon.h"
#include "server/daemon/daemon_command_line.h"

#include <spdlog/spdlog.h>

#include <csignal>
#include <cstring>
#include <iostream>
#include <pthread.h>

int main(int argc, char** argv) {
  using namespace pbgi::daemon;
  CommandLine command_line =
      parse_command_line(argc, argv, process_environment(), std::cout, std::cerr);
  if (!command_line.options) return command_line.exit_code;
  const DaemonOptions& options = *command_line.options;

  // Signals are taken synchronously with sigwait() below; they are blocked
  // before any thread exists so that every gRPC and TBB thread inherits
  // the mask and none of them is interrupted.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGINT);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  configure_logging(options.log_level, options.log_format);
  try {
    Daemon daemon(options);
    daemon.start();
    std::cout << "pbgid listening on " << daemon.address() << std::endl;

    int signal_number = 0;
    sigwait(&signals, &signal_number);
    const auto grace = std::chrono::milliseconds(
        static_cast<int64_t>(options.shutdown_grace_seconds * 1000.0));
    spdlog::info("{}: draining for up to {} s", strsignal(signal_number),
                 options.shutdown_grace_seconds);
    daemon.shutdown(grace);
    spdlog::info("stopped");
  } catch (const std::exception& e) {
    spdlog::critical("{}", e.what());
    return 1;
  }
  return 0;
}
