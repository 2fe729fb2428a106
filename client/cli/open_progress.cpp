#include "client/cli/open_progress.h"

#include <algorithm>
#include <cmath>

namespace pbgi::cli {

std::string open_progress_text(const v1::OpenSceneEvent::Progress& p) {
  char text[96];
  const float percent = 100.f * std::clamp(p.fraction(), 0.f, 1.f);
  if (p.eta_seconds() >= 0) {
    std::snprintf(text, sizeof text, " %3.0f%% (%.1f s, eta %.1f s)", percent, p.elapsed_seconds(), p.eta_seconds());
  } else {
    std::snprintf(text, sizeof text, " %3.0f%% (%.1f s)", percent, p.elapsed_seconds());
  }
  return p.stage() + text;
}

OpenProgressPrinter::OpenProgressPrinter(std::FILE* out, bool tty, bool quiet)
    : out_(out), tty_(tty), quiet_(quiet) {}

void OpenProgressPrinter::operator()(const v1::OpenSceneEvent::Progress& p) {
  if (quiet_) return;
  const int quarter = int(std::floor(4.f * std::clamp(p.fraction(), 0.f, 1.f)));
  if (tty_) {
    // Padded so that a shorter line covers a longer one before it.
    std::fprintf(out_, "\ropen: %-60s", open_progress_text(p).c_str());
  } else if (p.stage() != stage_ || quarter > quarter_) {
    std::fprintf(out_, "open: %s\n", open_progress_text(p).c_str());
  }
  if (p.stage() != stage_) quarter_ = -1;
  stage_ = p.stage();
  quarter_ = std::max(quarter_, quarter);
  std::fflush(out_);
}

void OpenProgressPrinter::done() {
  if (!quiet_ && tty_ && !stage_.empty()) std::fputc('\n', out_);
}

}  // namespace pbgi::cli
