// Runs scripts/plot_bench.py (matplotlib, in the project's venv) on a
// bench.json to draw the speed-vs-error figure.
//
// Thread-safety: reentrant; spawns a child process and waits for it.
#pragma once

#include <filesystem>
#include <string>

namespace pbgi::bench {

// Exit status of plot_bench.py when matplotlib cannot be imported.
inline constexpr int kPlotNoMatplotlib = 3;

struct PlotOutcome {
  enum class Status { Written, NoMatplotlib, Failed } status = Status::Failed;
  std::string message;  // why it failed or was skipped
};

// `python script json png`. "" python = PBGI_PYTHON of this build, "" script
// = <PBGI_SOURCE_DIR>/scripts/plot_bench.py. Never throws for a failing
// script (a missing plot is not worth losing the measurements): the
// outcome says what happened.
PlotOutcome run_plot_script(const std::string& python, const std::filesystem::path& script,
                            const std::filesystem::path& json, const std::filesystem::path& png);

}  // namespace pbgi::bench
