#include "client/bench/plot_runner.h"

#include "pbgi_build_config.h"

#include <fmt/format.h>

#include <cerrno>
#include <cstring>
#include <spawn.h>
#include <sys/wait.h>
#include <vector>

extern char** environ;

namespace pbgi::bench {

PlotOutcome run_plot_script(const std::string& python_arg, const std::filesystem::path& script_arg,
                            const std::filesystem::path& json, const std::filesystem::path& png) {
  const std::string python = python_arg.empty() ? std::string(PBGI_PYTHON) : python_arg;
  const std::string script = script_arg.empty()
                                 ? std::string(PBGI_SOURCE_DIR) + "/scripts/plot_bench.py"
                                 : script_arg.string();
  std::vector<std::string> args{python, script, json.string(), png.string()};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);

  PlotOutcome out;
  pid_t pid = 0;
  const int err = posix_spawnp(&pid, python.c_str(), nullptr, nullptr, argv.data(), environ);
  if (err != 0) {
    out.message = fmt::format("cannot start {}: {}", python, std::strerror(err));
    return out;
  }
  int status = 0;
  while (waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) {
      out.message = fmt::format("waiting for {}: {}", script, std::strerror(errno));
      return out;
    }
  }
  if (WIFEXITED(status) && WEXITSTATUS(status) == 0) {
    out.status = PlotOutcome::Status::Written;
  } else if (WIFEXITED(status) && WEXITSTATUS(status) == kPlotNoMatplotlib) {
    out.status = PlotOutcome::Status::NoMatplotlib;
    out.message = fmt::format("{} has no matplotlib; no plot written", python);
  } else {
    out.message = WIFEXITED(status)
                      ? fmt::format("{} {} exited with status {}", python, script, WEXITSTATUS(status))
                      : fmt::format("{} {} killed by signal {}", python, script, WTERMSIG(status));
  }
  return out;
}

}  // namespace pbgi::bench
