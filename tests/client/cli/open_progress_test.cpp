// Opening a scene shows the daemon's percentage and time left, like the
// tiles do; in a log, a line per stage and per quarter of it.
#include "client/cli/open_progress.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <string>

namespace pbgi::cli {
namespace {

v1::OpenSceneEvent::Progress progress(const std::string& stage, float fraction, double eta, double elapsed) {
  v1::OpenSceneEvent::Progress p;
  p.set_stage(stage);
  p.set_fraction(fraction);
  p.set_eta_seconds(eta);
  p.set_elapsed_seconds(elapsed);
  return p;
}

TEST(OpenProgress, TextHasPercentElapsedAndEta) {
  EXPECT_EQ(open_progress_text(progress("sample_surfels", 0.5f, 11.04, 12.3)),
            "sample_surfels  50% (12.3 s, eta 11.0 s)");
  EXPECT_EQ(open_progress_text(progress("read", 0.f, -1, 0.3)), "read   0% (0.3 s)");  // eta unknown
}

TEST(OpenProgress, LogGetsALinePerStageAndQuarter) {
  std::FILE* f = std::tmpfile();
  ASSERT_NE(f, nullptr);
  OpenProgressPrinter print(f, /*tty=*/false, /*quiet=*/false);
  for (float x : {0.f, 0.1f, 0.2f, 0.3f, 0.6f, 0.65f, 1.f}) print(progress("build", x, 1, 1));
  print(progress("ready", 1.f, 0, 2));
  print.done();
  std::rewind(f);
  std::string text;
  for (int c; (c = std::fgetc(f)) != EOF;) text += char(c);
  std::fclose(f);
  EXPECT_EQ(text,
            "open: build   0% (1.0 s, eta 1.0 s)\n"
            "open: build  30% (1.0 s, eta 1.0 s)\n"
            "open: build  60% (1.0 s, eta 1.0 s)\n"
            "open: build 100% (1.0 s, eta 1.0 s)\n"
            "open: ready 100% (2.0 s, eta 0.0 s)\n");
}

}  // namespace
}  // namespace pbgi::cli
