// Progress of an OpenScene on stderr, like the tiles' progress after it:
// the daemon's stage, its percentage and the stage's estimated time left
// (OpenSceneEvent.Progress). On a terminal one line redrawn in place;
// otherwise a line per stage and per quarter of it, so logs stay readable.
#pragma once

#include "pbgi/v1/pbgi.pb.h"

#include <cstdio>
#include <string>

namespace pbgi::cli {

class OpenProgressPrinter {
 public:
  // `tty`: redraw in place (isatty of `out`, unless a test says otherwise).
  OpenProgressPrinter(std::FILE* out, bool tty, bool quiet);

  void operator()(const v1::OpenSceneEvent::Progress& p);
  // Ends the redrawn line (a terminal) once the scene is open.
  void done();

 private:
  std::FILE* out_;
  bool tty_, quiet_;
  std::string stage_;
  int quarter_ = -1;
};

// "<stage> <percent>% (<elapsed> s, eta <eta> s)"; the eta is left out
// while the daemon cannot tell (eta_seconds < 0).
std::string open_progress_text(const v1::OpenSceneEvent::Progress& p);

}  // namespace pbgi::cli
