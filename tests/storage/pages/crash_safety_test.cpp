// Crash safety of the page-set build: a child process building a page set
// is killed with SIGKILL at moments spread over its whole build (sorting,
// merging, writing pages, publishing). Afterwards the target directory
// either does not exist or holds a complete page set, identical byte for
// byte to an uninterrupted build; and the next build in the same parent
// removes the staging directories the killed builds left behind.
#include "common/errors.h"
#include "storage/pages/page_set.h"
#include "storage/pages/page_set_inspection.h"
#include "tests/storage/pages/crash_test_options.h"
#include "tests/storage/pages/temp_dir.h"
#include "tests/storage/tree/random_surfels.h"

#include <gtest/gtest.h>

#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <string>
#include <cstring>
#include <thread>
#include <vector>

extern char** environ;

namespace pbgi::storage {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

constexpr uint64_t kSurfels = 30000;
constexpr uint32_t kSeed = 23;

std::vector<uint8_t> read_file(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), {}};
}

pid_t spawn_build(const fs::path& dir) {
  const std::string exe = PBGI_BUILD_CHILD;
  const std::string count = std::to_string(kSurfels), seed = std::to_string(kSeed);
  std::vector<char*> argv{const_cast<char*>(exe.c_str()), const_cast<char*>(dir.c_str()),
                          const_cast<char*>(count.c_str()), const_cast<char*>(seed.c_str()), nullptr};
  pid_t pid = 0;
  const int rc = posix_spawn(&pid, exe.c_str(), nullptr, nullptr, argv.data(), environ);
  if (rc != 0) throw IoError("posix_spawn " + exe + ": " + std::strerror(rc));
  return pid;
}

int wait_exit(pid_t pid) {
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {}
  return status;
}

size_t staging_dirs(const fs::path& parent) {
  size_t n = 0;
  for (const auto& e : fs::directory_iterator(parent))
    if (e.path().filename().string().find(".tmp-") != std::string::npos) ++n;
  return n;
}

TEST(CrashSafety, KilledBuildsPublishNothingOrEverything) {
  test::TempDir tmp;
  // 1. The reference: an uninterrupted build in a child, timed.
  const auto t0 = Clock::now();
  const pid_t ref = spawn_build(tmp.path() / "reference");
  const int status = wait_exit(ref);
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  const double build_seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  const auto ref_manifest = read_file(tmp.path() / "reference" / kManifestFileName);
  const auto ref_pages = read_file(tmp.path() / "reference" / kPagesFileName);
  ASSERT_FALSE(ref_pages.empty());

  // 2. Kills spread over [0, 1.2] x the build time, the end (publish) included.
  constexpr int kKills = 10;
  int published = 0, absent = 0, left_staging = 0;
  for (int k = 0; k < kKills; ++k) {
    const fs::path dir = tmp.path() / ("set-" + std::to_string(k));
    const pid_t pid = spawn_build(dir);
    std::this_thread::sleep_for(std::chrono::duration<double>(build_seconds * 1.2 * k / (kKills - 1)));
    ::kill(pid, SIGKILL);
    wait_exit(pid);
    // (The next child's build removes this kill's staging directory.)
    if (staging_dirs(tmp.path()) > 0) ++left_staging;
    if (!fs::exists(dir)) {
      ++absent;
      continue;
    }
    // Published: complete, valid, and the same bytes as the reference.
    ++published;
    PageSetReader reader(dir, nullptr);
    const PageSetInspection r = inspect_page_set(reader);
    EXPECT_TRUE(r.consistent) << dir;
    EXPECT_EQ(r.surfels, kSurfels) << dir;
    EXPECT_EQ(read_file(dir / kManifestFileName), ref_manifest) << dir;
    EXPECT_EQ(read_file(dir / kPagesFileName), ref_pages) << dir;
  }
  std::printf("%d kills: %d left nothing published, %d a complete page set, %d a staging directory\n", kKills,
              absent, published, left_staging);
  EXPECT_GT(absent, 0);        // the early kills at least
  EXPECT_GT(left_staging, 0);  // kills during the build

  // 3. The next build in the same parent removes what the killed ones left.
  if (staging_dirs(tmp.path()) == 0) {
    const pid_t pid = spawn_build(tmp.path() / "last");  // leave one for sure
    std::this_thread::sleep_for(std::chrono::duration<double>(build_seconds * 0.5));
    ::kill(pid, SIGKILL);
    wait_exit(pid);
  }
  EXPECT_GT(staging_dirs(tmp.path()), 0u);
  build_page_set(test::random_surfels(100, 1), test::crash_test_options(), "next", tmp.path() / "next");
  EXPECT_EQ(staging_dirs(tmp.path()), 0u);
}

TEST(CrashSafety, StaleStagingDirsOfDeadProcessesOnly) {
  test::TempDir tmp;
  // A process id that is certainly dead: a child that has exited and been
  // reaped (ids are not reused immediately).
  const pid_t dead = fork();
  if (dead == 0) _exit(0);
  wait_exit(dead);
  const fs::path stale = tmp.path() / ("a.tmp-" + std::to_string(dead) + "-0123456789abcdef");
  const fs::path mine = tmp.path() / ("b.tmp-" + std::to_string(::getpid()) + "-0123456789abcdef");
  const fs::path other = tmp.path() / "c.tmp-not-a-staging-dir";
  for (const fs::path& d : {stale, mine, other}) {
    fs::create_directories(d);
    std::ofstream(d / "pages.pbgp") << "partial";
  }
  build_page_set(test::random_surfels(100, 1), {}, "k", tmp.path() / "set");
  EXPECT_FALSE(fs::exists(stale));
  EXPECT_TRUE(fs::exists(mine));   // a live build (this process) is never touched
  EXPECT_TRUE(fs::exists(other));  // not a name a build uses
  EXPECT_TRUE(fs::exists(tmp.path() / "set" / kManifestFileName));
}

}  // namespace
}  // namespace pbgi::storage
