// The CI soak: `pbgi stress` with 4 clients for 30 s (PBGI_SOAK_SECONDS
// overrides) against a daemon with a 256 MiB page cache, sampling its RSS.
// Every request must succeed and the RSS must stay bounded: below the
// budget plus what the daemon held after opening the scene, and not
// growing over the second half of the run. scripts/soak.sh runs the long
// version (10 minutes, 16 clients) with a plot.
#include "tests/reliability/reliability_env.h"

#include <cstdlib>
#include <regex>

namespace fs = std::filesystem;

namespace pbgi::testing {
namespace {

// The number after "key": in the JSON report (-1 if absent).
double json_number(const std::string& json, const std::string& key) {
  const std::regex re("\"" + key + "\": (-?[0-9.eE+-]+)");
  std::smatch m;
  if (!std::regex_search(json, m, re)) return -1;
  return std::stod(m[1].str());
}

TEST(Soak, ShortSoakHasNoErrorAndBoundedRss) {
  const char* env = std::getenv("PBGI_SOAK_SECONDS");
  const int seconds = env && *env ? std::atoi(env) : 30;
  TempDir tmp;
  auto d = start_daemon(tmp, "d", tmp / "cache");
  const fs::path csv = tmp / "rss.csv";
  const std::string command =
      kPbgi.string() + " stress --server " + d->address() + " --scene " + kCornell.string() +
      " --camera /Camera --clients 4 --duration " + std::to_string(seconds) +
      "s --image 32x32 --tile 8 --target-surfels 20000 --build-light-samples 4"
      " --light-samples 4 --daemon-pid " + std::to_string(d->pid()) + " --rss-csv " +
      csv.string() + " --rss-interval 0.25 --max-rss 1GiB --json -q";
  const CommandResult r = run_command(command);
  ASSERT_EQ(r.status, 0) << r.out << "\n" << d->log();
  std::printf("%s", r.out.c_str());
  EXPECT_EQ(json_number(r.out, "errors"), 0) << r.out;
  EXPECT_GT(json_number(r.out, "requests"), seconds) << "too little load to mean anything";
  EXPECT_LT(json_number(r.out, "p99"), 5000) << r.out;
  // Bounded: peak within the 256 MiB budget of the end-of-open RSS level
  // (the start sample is taken before the open), no growth late in the run.
  const double peak = json_number(r.out, "peak_bytes");
  const double growth = json_number(r.out, "growth_bytes");
  EXPECT_GT(peak, 0);
  EXPECT_LT(peak, 1024.0 * 1024 * 1024);
  EXPECT_LT(growth, 32.0 * 1024 * 1024) << "RSS kept growing under a steady load";
  EXPECT_TRUE(fs::exists(csv));
  EXPECT_GT(fs::file_size(csv), 100u);
  EXPECT_EQ(d->terminate(), 0) << d->log();
}

// A load test must be able to ask for what a render asks for (the surfel
// spacing, FPBGI, a payload codec...): `pbgi stress` takes `pbgi render`'s
// build and gather flags, from the same tables, not a hand-picked few.
TEST(Soak, StressTakesTheRenderCommandsBuildAndGatherFlags) {
  const CommandResult render = run_command(kPbgi.string() + " render --help");
  const CommandResult stress = run_command(kPbgi.string() + " stress --help");
  ASSERT_EQ(render.status, 0) << render.out;
  ASSERT_EQ(stress.status, 0) << stress.out;
  for (const char* flag : {"--surfel-spacing", "--target-surfels", "--payload", "--bounces", "--method", "--epsilon",
                           "--mb-res", "--max-solid-angle", "--light-samples"}) {
    ASSERT_NE(render.out.find(flag), std::string::npos) << flag << " is not a render flag";
    EXPECT_NE(stress.out.find(flag), std::string::npos) << "pbgi stress has no " << flag;
  }
}

}  // namespace
}  // namespace pbgi::testing
