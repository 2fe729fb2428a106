// pbgid: the PBGI daemon. Thin: parse the command line, start the Daemon,
// wait for SIGTERM/SIGINT, drain; a second signal during the drain exits at
// once (what is left staged is removed by the next build, StagingDir).
#include "server/daemon/daemon.h"
#include "server/daemon/daemon_command_line.h"

#include <spdlog/spdlog.h>

#include <atomic>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <thread>
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
    // The drain runs on its own thread so that this one can take a second
    // signal: the operator's (or the service manager's) "now".
    std::atomic<bool> drained{false};
    std::thread drain([&] {
      daemon.shutdown(grace);
      drained = true;
    });
    while (!drained) {
      const timespec poll{0, 50'000'000};
      const int again = sigtimedwait(&signals, nullptr, &poll);
      if (again > 0) {
        spdlog::warn("{} again: exiting without waiting for in-flight requests", strsignal(again));
        spdlog::default_logger()->flush();
        std::_Exit(128 + again);
      }
    }
    drain.join();
    spdlog::info("stopped");
  } catch (const std::exception& e) {
    spdlog::critical("{}", e.what());
    return 1;
  }
  return 0;
}
