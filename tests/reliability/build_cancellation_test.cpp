// Scene builds in a real pbgid are cancellable and bounded (issue 17):
//   - a build whose only client disconnects, or whose deadline passes, is
//     cancelled and its staging directory removed;
//   - SIGTERM during a build: the daemon exits within shutdown_grace_seconds
//     plus a margin, the build cancelled and cleaned up; a second signal
//     exits at once;
//   - a build above limits.max_surfels is refused with RESOURCE_EXHAUSTED
//     naming the limit, before any work; one that would pass the staging
//     quota stops with RESOURCE_EXHAUSTED naming it and leaves nothing.
#include "tests/reliability/reliability_env.h"

#include <grpcpp/grpcpp.h>

#include <csignal>
#include <functional>
#include <thread>

namespace fs = std::filesystem;

namespace pbgi::testing {
namespace {

using client::PbgiClient;
using client::RpcError;
using Clock = std::chrono::steady_clock;

// Minutes of sampling on two cores: a build that is still running whenever
// a test stops it (well inside the default limits).
constexpr uint64_t kEndlessBuild = 20'000'000;
// How long a dropped build may take to be gone: far shorter than
// kEndlessBuild takes, so what a test sees happen within it is the
// daemon's doing, not a build that ended by itself.
constexpr auto kCleanupLimit = std::chrono::seconds(10);

// Polls `done` every 50 ms for up to `limit`.
bool eventually(const std::function<bool()>& done, std::chrono::seconds limit = kCleanupLimit) {
  const auto end = Clock::now() + limit;
  while (!done()) {
    if (Clock::now() >= end) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return true;
}

// An OpenScene stream driven by hand, so that the test can leave it.
class OpenStream {
 public:
  OpenStream(const std::string& address, uint64_t surfels, std::chrono::milliseconds deadline = {})
      : stub_(v1::Pbgi::NewStub(grpc::CreateChannel(address, grpc::InsecureChannelCredentials()))) {
    v1::OpenSceneRequest request;
    request.set_scene_path(kCornell.string());
    *request.mutable_build() = build_with(surfels);
    if (deadline.count() > 0) context_.set_deadline(std::chrono::system_clock::now() + deadline);
    reader_ = stub_->OpenScene(&context_, request);
  }

  // Reads events until one reports `stage` (true) or the stream ends.
  bool wait_for_stage(const std::string& stage) {
    v1::OpenSceneEvent event;
    while (reader_->Read(&event)) {
      if (event.has_progress() && event.progress().stage() == stage) return true;
    }
    return false;
  }
  void cancel() { context_.TryCancel(); }
  grpc::Status finish() {
    v1::OpenSceneEvent event;
    while (reader_->Read(&event)) {
    }
    return reader_->Finish();
  }

 private:
  std::unique_ptr<v1::Pbgi::Stub> stub_;
  grpc::ClientContext context_;
  std::unique_ptr<grpc::ClientReader<v1::OpenSceneEvent>> reader_;
};

// Nothing building, nothing staged: the daemon has dropped the build.
bool build_dropped(DaemonInstance& daemon, const fs::path& cache) {
  PbgiClient client(daemon.address(), no_retry());
  return client.status().opening_size() == 0 && entries_named(cache, ".tmp-").empty();
}

// Opening the Cornell box with `build` is refused with RESOURCE_EXHAUSTED,
// the message naming `limit`.
void expect_exhausted(PbgiClient& client, const v1::BuildOptions& build, const std::string& limit) {
  try {
    client.open_scene(kCornell.string(), build);
    ADD_FAILURE() << "built within " << limit << ": " << build.ShortDebugString();
  } catch (const RpcError& e) {
    EXPECT_EQ(e.code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << e.what();
    EXPECT_NE(e.server_message().find(limit), std::string::npos) << e.what();
  }
}

// After a build was dropped the daemon still builds and serves.
void expect_still_serving(DaemonInstance& daemon) {
  PbgiClient client(daemon.address(), no_retry());
  const v1::SceneInfo info = client.open_scene(kCornell.string(), build_with(5000));
  EXPECT_GT(info.surfel_count(), 0u);
}

TEST(BuildCancellation, BuildWhoseOnlyClientLeavesIsCancelledAndItsStagingRemoved) {
  TempDir tmp;
  const fs::path cache = tmp / "cache";
  auto daemon = start_daemon(tmp, "d", cache);
  OpenStream open(daemon->address(), kEndlessBuild);
  ASSERT_TRUE(open.wait_for_stage("sample_surfels")) << daemon->log();
  EXPECT_EQ(entries_named(cache, ".tmp-").size(), 1u) << "the build stages into its directory";
  open.cancel();
  EXPECT_EQ(open.finish().error_code(), grpc::StatusCode::CANCELLED);
  EXPECT_TRUE(eventually([&] { return build_dropped(*daemon, cache); }))
      << "the build went on for a client that left\n" << daemon->log();
  EXPECT_TRUE(published_page_sets(cache).empty());
  expect_still_serving(*daemon);
  EXPECT_EQ(daemon->terminate(), 0) << daemon->log();
}

TEST(BuildCancellation, BuildPastItsClientsDeadlineIsCancelledAndItsStagingRemoved) {
  TempDir tmp;
  const fs::path cache = tmp / "cache";
  auto daemon = start_daemon(tmp, "d", cache);
  OpenStream open(daemon->address(), kEndlessBuild, std::chrono::seconds(4));
  EXPECT_EQ(open.finish().error_code(), grpc::StatusCode::DEADLINE_EXCEEDED);
  EXPECT_TRUE(eventually([&] { return build_dropped(*daemon, cache); }))
      << "the build went on past its client's deadline\n" << daemon->log();
  expect_still_serving(*daemon);
  EXPECT_EQ(daemon->terminate(), 0) << daemon->log();
}

TEST(BuildCancellation, SigtermDuringABuildExitsWithinTheGracePeriod) {
  TempDir tmp;
  const fs::path cache = tmp / "cache";
  auto daemon = start_daemon(tmp, "d", cache, 0, {"--shutdown-grace", "1"});
  OpenStream open(daemon->address(), kEndlessBuild);
  ASSERT_TRUE(open.wait_for_stage("sample_surfels")) << daemon->log();
  // 1 s of grace, then the build is cancelled; a few seconds of margin
  // for it to stop on a loaded machine.
  const int status = daemon->terminate(std::chrono::seconds(6));
  EXPECT_EQ(status, 0) << (status == -1 ? "still running 6 s after SIGTERM with a 1 s grace\n" : "")
                       << daemon->log();
  EXPECT_TRUE(entries_named(cache, ".tmp-").empty()) << "the cancelled build removed its staging directory";
  EXPECT_TRUE(published_page_sets(cache).empty());
  EXPECT_NE(open.finish().error_code(), grpc::StatusCode::OK);
}

TEST(BuildCancellation, SecondSignalExitsAtOnce) {
  TempDir tmp;
  const fs::path cache = tmp / "cache";
  auto daemon = start_daemon(tmp, "d", cache, 0, {"--shutdown-grace", "60"});
  OpenStream open(daemon->address(), kEndlessBuild);
  ASSERT_TRUE(open.wait_for_stage("sample_surfels")) << daemon->log();
  EXPECT_EQ(daemon->terminate(std::chrono::milliseconds(500)), -1)
      << "the build in flight has 60 s of grace\n" << daemon->log();
  const int status = daemon->terminate(std::chrono::seconds(5));
  EXPECT_EQ(status, 128 + SIGTERM) << (status == -1 ? "a second SIGTERM did not stop the daemon\n" : "")
                                   << daemon->log();
  EXPECT_NE(daemon->stderr_log().find("exiting without waiting"), std::string::npos) << daemon->log();
}

TEST(BuildLimits, BuildAboveMaxSurfelsIsRefusedNamingTheLimit) {
  TempDir tmp;
  const fs::path cache = tmp / "cache";
  auto daemon = start_daemon(tmp, "d", cache, 0, {"--max-surfels", "50000"});
  PbgiClient client(daemon->address(), no_retry());
  // Asked for by count: refused before the scene is read.
  expect_exhausted(client, build_with(60000), "limits.max_surfels = 50000");
  // Asked for by spacing (1 mm over the box: millions of surfels): refused
  // once the scene's area is known, before any surfel.
  v1::BuildOptions fine = build_with(0);
  fine.set_surfel_spacing(0.001f);
  expect_exhausted(client, fine, "limits.max_surfels = 50000");
  EXPECT_TRUE(entries_named(cache, ".tmp-").empty());
  EXPECT_TRUE(published_page_sets(cache).empty());
  // At the limit: built.
  EXPECT_GT(client.open_scene(kCornell.string(), build_with(50000)).surfel_count(), 40000u);
  EXPECT_EQ(daemon->terminate(), 0) << daemon->log();
}

TEST(BuildLimits, BuildOverTheStagingQuotaStopsAndCleansUp) {
  TempDir tmp;
  const fs::path cache = tmp / "cache";
  auto daemon = start_daemon(tmp, "d", cache, 0, {"--staging-quota", "1MiB"});
  PbgiClient client(daemon->address(), no_retry());
  // ~16 bytes per surfel of pages (V10 pages of the Cornell box): 2 MB.
  expect_exhausted(client, build_with(125000), "staging_quota of 1048576 bytes");
  EXPECT_TRUE(entries_named(cache, ".tmp-").empty()) << "the stopped build removed its staging directory";
  EXPECT_TRUE(published_page_sets(cache).empty());
  // A build that fits is not held back by the one that did not.
  EXPECT_GT(client.open_scene(kCornell.string(), build_with(5000)).surfel_count(), 0u);
  EXPECT_EQ(daemon->terminate(), 0) << daemon->log();
}

}  // namespace
}  // namespace pbgi::testing
