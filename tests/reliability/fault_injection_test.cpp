// Faults injected into a real pbgid (child process on a temporary cache):
//   - kill -9 while a page set is being built (surfel stage, page writing),
//     then a restart on the same cache: no partial page set is ever
//     published or used, the scene opens and renders;
//   - kill -9 while serving, then a restart: the page set is reused and
//     renders the same pixels, every request after the restart succeeds;
//   - bytes flipped in a page on disk: DATA_LOSS naming the page, in the
//     reply and the daemon's log, never different pixels; a flipped
//     manifest: the set is moved aside and rebuilt;
//   - a disk that fills during a build (RLIMIT_FSIZE in the daemon): a
//     clean error, nothing left behind, the previous page set intact;
//   - clients leaving (cancel, deadline) in the middle of a RenderTile or a
//     Gather: the daemon stops working on it (its CPU time stops growing),
//     and one leaving an OpenScene stream leaves the scene openable (the
//     build it left is cancelled: build_cancellation_test.cpp).
#include "storage/pages/page_set.h"
#include "tests/reliability/reliability_env.h"

#include <grpcpp/grpcpp.h>

#include <atomic>
#include <cmath>
#include <fstream>
#include <thread>

namespace fs = std::filesystem;

namespace pbgi::testing {
namespace {

using client::PbgiClient;
using client::RpcError;
using Clock = std::chrono::steady_clock;

// Big enough that the build takes a noticeable time (the kill has to land
// inside it), small enough for CI.
constexpr uint64_t kBigBuild = 400000;
constexpr uint64_t kSmallBuild = 20000;

bool all_finite(const client::Frame& f) {
  for (float v : f.beauty) {
    if (!std::isfinite(v)) return false;
  }
  return true;
}

double mean(const std::vector<float>& v) {
  double s = 0;
  for (float x : v) s += x;
  return v.empty() ? 0 : s / v.size();
}

std::string file_bytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// Kills the daemon when the build reports `stage` past 20%, restarts on the
// same cache and checks that nothing partial was published or used.
void kill_during_build_then_restart(const std::string& stage) {
  TempDir tmp;
  const fs::path cache = tmp / "cache";
  auto a = start_daemon(tmp, "a", cache);
  std::string stages;
  bool killed = false;
  {
    PbgiClient client(a->address(), no_retry());
    try {
      client.open_scene(kCornell.string(), build_with(kBigBuild),
                        [&](const std::string& s, float f) {
                          if (stages.find(s + ";") == std::string::npos) stages += s + ";";
                          if (!killed && s == stage && f > 0.2f && f < 1.f) {
                            a->kill9();
                            killed = true;
                          }
                        });
      FAIL() << "the build finished before reaching " << stage << " (stages: " << stages << ")";
    } catch (const RpcError& e) {
      ASSERT_TRUE(killed) << e.what() << "\n" << a->log();
      EXPECT_EQ(e.code(), grpc::StatusCode::UNAVAILABLE) << e.what();
    }
  }
  // Killed in the middle: nothing is published (the build wrote into a
  // staging directory only).
  EXPECT_TRUE(published_page_sets(cache).empty()) << "a partial page set was published";
  const size_t stale = entries_named(cache, ".tmp-").size();

  auto b = start_daemon(tmp, "b", cache);
  PbgiClient client(b->address(), no_retry());
  const v1::SceneInfo info = client.open_scene(kCornell.string(), build_with(kBigBuild));
  EXPECT_FALSE(info.reused_cache()) << "nothing complete to reuse";
  EXPECT_GT(info.surfel_count(), kBigBuild / 2);
  EXPECT_TRUE(entries_named(cache, ".tmp-").empty())
      << stale << " staging dir(s) of the killed build must be removed by the next build";
  const auto sets = published_page_sets(cache);
  ASSERT_EQ(sets.size(), 1u);
  EXPECT_NO_THROW(storage::PageSetReader(sets[0], nullptr));
  const client::Frame frame = client::render_frame(client, frame_request(info.scene_id()));
  EXPECT_TRUE(all_finite(frame));
  EXPECT_GT(mean(frame.beauty), 0.0);
  EXPECT_EQ(b->terminate(), 0) << b->log();
}

TEST(FaultInjection, KillWhileSamplingSurfelsThenRestart) {
  kill_during_build_then_restart("sample_surfels");
}

TEST(FaultInjection, KillWhileWritingPagesThenRestart) { kill_during_build_then_restart("tree"); }

TEST(FaultInjection, KillWhileServingThenRestart) {
  TempDir tmp;
  const fs::path cache = tmp / "cache";
  auto a = start_daemon(tmp, "a", cache);
  PbgiClient first(a->address(), no_retry());
  const v1::SceneInfo info = first.open_scene(kCornell.string(), build_with(kSmallBuild));
  const client::Frame before = client::render_frame(first, frame_request(info.scene_id()));

  // Load from two threads; kill -9 in the middle of it.
  std::atomic<bool> stop{false};
  std::atomic<int> ok{0}, failed{0};
  std::vector<std::thread> load;
  for (int t = 0; t < 2; ++t) {
    load.emplace_back([&, t] {
      PbgiClient c(a->address(), no_retry());
      v1::RenderTileRequest r;
      r.set_scene_id(info.scene_id());
      r.set_camera("/Camera");
      r.set_image_width(32);
      r.set_image_height(32);
      *r.mutable_options() = fast_gather();
      for (uint32_t i = 0; !stop; ++i) {
        const uint32_t x = 8 * ((i + t) % 4), y = 8 * ((i / 4) % 4);
        r.mutable_tile()->set_x0(x);
        r.mutable_tile()->set_y0(y);
        r.mutable_tile()->set_x1(x + 8);
        r.mutable_tile()->set_y1(y + 8);
        try {
          c.render_tile(r);
          ++ok;
        } catch (const RpcError&) {
          ++failed;
          std::this_thread::sleep_for(std::chrono::milliseconds(20));
        }
      }
    });
  }
  const auto end = Clock::now() + std::chrono::seconds(5);
  while (ok < 10 && Clock::now() < end) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  ASSERT_GE(ok.load(), 10) << "no load before the kill";
  EXPECT_EQ(a->kill9(), 128 + 9);
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  stop = true;
  for (auto& t : load) t.join();
  EXPECT_GT(failed.load(), 0) << "requests in flight or after the kill fail";

  // Restart on the same cache: the page set is reused and gives the same pixels.
  auto b = start_daemon(tmp, "b", cache);
  PbgiClient client(b->address(), no_retry());
  const v1::SceneInfo again = client.open_scene(kCornell.string(), build_with(kSmallBuild));
  EXPECT_TRUE(again.reused_cache());
  EXPECT_TRUE(again.reused_ingest()) << "the stored ingest, same pixels below";
  EXPECT_EQ(again.scene_id(), info.scene_id());
  for (int i = 0; i < 3; ++i) {
    const client::Frame after = client::render_frame(client, frame_request(again.scene_id()));
    EXPECT_TRUE(frames_identical(before, after));
  }
  EXPECT_EQ(b->terminate(), 0) << b->log();
}

TEST(FaultInjection, FlippedPageBytesAreDetectedReportedAndNeverServed) {
  TempDir tmp;
  const fs::path cache = tmp / "cache";
  std::string scene_id;
  client::Frame before;
  {
    auto a = start_daemon(tmp, "a", cache);
    PbgiClient client(a->address(), no_retry());
    scene_id = client.open_scene(kCornell.string(), build_with(kSmallBuild)).scene_id();
    before = client::render_frame(client, frame_request(scene_id));
    ASSERT_EQ(a->terminate(), 0);
  }
  // Flip 16 bytes in the middle of the root page (every gather reads it).
  const fs::path set = cache / scene_id;
  const storage::Manifest manifest = storage::PageSetReader(set, nullptr).manifest();
  const uint32_t page = manifest.root.page;
  const storage::PageExtent extent = manifest.pages.at(page);
  {
    std::fstream f(set / storage::kPagesFileName, std::ios::in | std::ios::out | std::ios::binary);
    const uint64_t at = extent.offset + extent.bytes / 2;
    f.seekg(at);
    char bytes[16];
    f.read(bytes, sizeof bytes);
    for (char& c : bytes) c = static_cast<char>(~c);
    f.seekp(at);
    f.write(bytes, sizeof bytes);
    ASSERT_TRUE(f.good());
  }

  auto b = start_daemon(tmp, "b", cache);
  PbgiClient client(b->address(), no_retry());
  const v1::SceneInfo info = client.open_scene(kCornell.string(), build_with(kSmallBuild));
  const std::string page_name = "page " + std::to_string(page);
  // Either a clear error naming the page, or (after a rebuild) the same
  // pixels: never different ones. Asked twice: a failed load is not cached.
  for (int attempt = 0; attempt < 2; ++attempt) {
    try {
      const client::Frame after = client::render_frame(client, frame_request(info.scene_id()));
      EXPECT_TRUE(frames_identical(before, after)) << "corrupt page served";
    } catch (const RpcError& e) {
      std::printf("[ corrupt page ] %s\n", e.what());
      EXPECT_EQ(e.code(), grpc::StatusCode::DATA_LOSS) << e.what();
      EXPECT_NE(e.server_message().find(page_name), std::string::npos) << e.what();
      EXPECT_NE(e.server_message().find("checksum"), std::string::npos) << e.what();
    }
  }
  EXPECT_NE(b->stderr_log().find(page_name), std::string::npos)
      << "the daemon's log names the corrupt page\n" << b->log();
  // The daemon keeps serving.
  EXPECT_EQ(client.list_scenes().size(), 1u);
  EXPECT_EQ(b->terminate(), 0) << b->log();
}

TEST(FaultInjection, CorruptManifestIsMovedAsideAndRebuilt) {
  TempDir tmp;
  const fs::path cache = tmp / "cache";
  std::string scene_id;
  client::Frame before;
  {
    auto a = start_daemon(tmp, "a", cache);
    PbgiClient client(a->address(), no_retry());
    scene_id = client.open_scene(kCornell.string(), build_with(kSmallBuild)).scene_id();
    before = client::render_frame(client, frame_request(scene_id));
    ASSERT_EQ(a->terminate(), 0);
  }
  {
    const fs::path manifest = cache / scene_id / storage::kManifestFileName;
    std::fstream f(manifest, std::ios::in | std::ios::out | std::ios::binary);
    f.seekg(fs::file_size(manifest) / 2);
    char c = 0;
    f.read(&c, 1);
    c = static_cast<char>(c ^ 0x5a);
    f.seekp(fs::file_size(manifest) / 2);
    f.write(&c, 1);
    ASSERT_TRUE(f.good());
  }
  auto b = start_daemon(tmp, "b", cache);
  PbgiClient client(b->address(), no_retry());
  const v1::SceneInfo info = client.open_scene(kCornell.string(), build_with(kSmallBuild));
  EXPECT_FALSE(info.reused_cache()) << "a corrupt manifest is never used";
  EXPECT_EQ(info.scene_id(), scene_id);
  EXPECT_EQ(entries_named(cache, ".corrupt-").size(), 1u) << "kept aside for inspection";
  EXPECT_NE(b->stderr_log().find("failed verification"), std::string::npos) << b->log();
  const client::Frame after = client::render_frame(client, frame_request(info.scene_id()));
  EXPECT_TRUE(frames_identical(before, after)) << "the rebuild is deterministic";
  EXPECT_EQ(b->terminate(), 0) << b->log();
}

TEST(FaultInjection, DiskFullDuringBuildFailsCleanlyAndKeepsPreviousPageSets) {
  TempDir tmp;
  const fs::path cache = tmp / "cache";
  std::string small_id;
  client::Frame before;
  {
    auto a = start_daemon(tmp, "a", cache);
    PbgiClient client(a->address(), no_retry());
    small_id = client.open_scene(kCornell.string(), build_with(5000)).scene_id();
    before = client::render_frame(client, frame_request(small_id));
    ASSERT_EQ(a->terminate(), 0);
  }
  const fs::path small_set = cache / small_id;
  const std::string small_pages = file_bytes(small_set / storage::kPagesFileName);
  const std::string small_manifest = file_bytes(small_set / storage::kManifestFileName);

  // No file of the daemon may grow past 4x the small page set: the big
  // build (80x the surfels) runs out of "disk" while writing.
  const uint64_t limit = std::max<uint64_t>(4 * small_pages.size(), 256 * 1024);
  auto b = start_daemon(tmp, "b", cache, limit);
  PbgiClient client(b->address(), no_retry());
  try {
    client.open_scene(kCornell.string(), build_with(kBigBuild));
    FAIL() << "the build fit in " << limit << " bytes per file";
  } catch (const RpcError& e) {
    EXPECT_EQ(e.code(), grpc::StatusCode::FAILED_PRECONDITION) << e.what();
    EXPECT_NE(e.server_message().find("File too large"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(entries_named(cache, ".tmp-").empty()) << "the failed build cleaned up";
  ASSERT_EQ(published_page_sets(cache).size(), 1u);
  EXPECT_EQ(file_bytes(small_set / storage::kPagesFileName), small_pages);
  EXPECT_EQ(file_bytes(small_set / storage::kManifestFileName), small_manifest);

  // The same daemon still serves the previous page set, unchanged.
  const v1::SceneInfo info = client.open_scene(kCornell.string(), build_with(5000));
  EXPECT_TRUE(info.reused_cache());
  const client::Frame after = client::render_frame(client, frame_request(info.scene_id()));
  EXPECT_TRUE(frames_identical(before, after));
  EXPECT_EQ(b->terminate(), 0) << b->log();
}

// --- clients that leave -------------------------------------------------

class ClientLeaves : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    tmp = new TempDir;
    daemon = start_daemon(*tmp, "d", *tmp / "cache").release();
    PbgiClient client(daemon->address(), no_retry());
    scene_id = new std::string(client.open_scene(kCornell.string(), build_with(kSmallBuild)).scene_id());
  }
  static void TearDownTestSuite() {
    EXPECT_EQ(daemon->terminate(), 0) << daemon->log();
    delete daemon;
    delete scene_id;
    delete tmp;
  }

  // A RenderTile far too heavy to finish within the test (the whole
  // 256x256 image, minutes on two cores) made of many cheap rows: the
  // renderer polls cancellation once per image row.
  static v1::RenderTileRequest heavy_tile() {
    v1::RenderTileRequest r;
    r.set_scene_id(*scene_id);
    r.set_camera("/Camera");
    r.set_image_width(256);
    r.set_image_height(256);
    r.mutable_tile()->set_x1(256);
    r.mutable_tile()->set_y1(256);
    r.mutable_options()->set_light_samples(4);
    return r;
  }

  // Seconds until the daemon is idle: a 250 ms window in which it used
  // less than 30 ms of CPU. Negative if it is still busy after `limit`.
  static double seconds_until_idle(std::chrono::seconds limit) {
    const auto start = Clock::now();
    while (Clock::now() - start < limit) {
      const double c0 = process_cpu_seconds(daemon->pid());
      std::this_thread::sleep_for(std::chrono::milliseconds(250));
      if (process_cpu_seconds(daemon->pid()) - c0 < 0.03) {
        return std::chrono::duration<double>(Clock::now() - start).count();
      }
    }
    return -1;
  }

  // After the client left, the daemon goes idle within a few seconds (it
  // finishes the row or receiver block in hand) and still answers.
  static void expect_work_stopped(const char* what) {
    const double idle_after = seconds_until_idle(std::chrono::seconds(5));
    EXPECT_GE(idle_after, 0) << what << ": the daemon kept computing for a client that left";
    std::printf("[ %s ] daemon idle %.2f s after the client left\n", what, idle_after);
    PbgiClient client(daemon->address(), no_retry());
    client::FrameRequest small = frame_request(*scene_id, 16, 8);
    EXPECT_NO_THROW(client::render_frame(client, small)) << what;
  }

  static TempDir* tmp;
  static DaemonInstance* daemon;
  static std::string* scene_id;
};
TempDir* ClientLeaves::tmp = nullptr;
DaemonInstance* ClientLeaves::daemon = nullptr;
std::string* ClientLeaves::scene_id = nullptr;

TEST_F(ClientLeaves, CancelledRenderTileStopsTheWork) {
  auto channel = grpc::CreateChannel(daemon->address(), grpc::InsecureChannelCredentials());
  auto stub = v1::Pbgi::NewStub(channel);
  grpc::ClientContext context;
  v1::RenderTileResponse response;
  grpc::Status status;
  const double cpu0 = process_cpu_seconds(daemon->pid());
  std::thread call([&] { status = stub->RenderTile(&context, heavy_tile(), &response); });
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  const double busy = process_cpu_seconds(daemon->pid()) - cpu0;
  context.TryCancel();
  call.join();
  EXPECT_EQ(status.error_code(), grpc::StatusCode::CANCELLED) << status.error_message();
  EXPECT_GT(busy, 0.05) << "the request was being worked on when the client left";
  expect_work_stopped("cancelled RenderTile");
}

TEST_F(ClientLeaves, RenderTilePastItsDeadlineStopsTheWork) {
  client::ClientOptions options = no_retry();
  options.call_deadline = std::chrono::milliseconds(500);
  PbgiClient client(daemon->address(), options);
  try {
    client.render_tile(heavy_tile());
    FAIL() << "the heavy tile finished within 500 ms";
  } catch (const RpcError& e) {
    EXPECT_EQ(e.code(), grpc::StatusCode::DEADLINE_EXCEEDED) << e.what();
  }
  expect_work_stopped("RenderTile past its deadline");
}

// Regression: a cancelled Gather went on for more than 5 s when TBB's
// partitioner handed one body call tens of thousands of receivers; the
// gather now checks cancellation every 64 receivers inside the body.
TEST_F(ClientLeaves, CancelledGatherStopsTheWork) {
  // 500k receivers on the floor, many light samples.
  v1::GatherRequest request;
  request.set_scene_id(*scene_id);
  std::vector<float> p, n;
  for (int i = 0; i < 500000; ++i) {
    p.insert(p.end(), {-0.9f + 1.8f * float(i % 700) / 700.f, 0.01f, -0.9f + 1.8f * float(i / 700) / 715.f});
    n.insert(n.end(), {0.f, 1.f, 0.f});
  }
  request.set_positions(std::string(reinterpret_cast<const char*>(p.data()), p.size() * 4));
  request.set_normals(std::string(reinterpret_cast<const char*>(n.data()), n.size() * 4));
  request.mutable_options()->set_light_samples(4);
  auto channel = grpc::CreateChannel(daemon->address(), grpc::InsecureChannelCredentials());
  auto stub = v1::Pbgi::NewStub(channel);
  grpc::ClientContext context;
  v1::GatherResponse response;
  grpc::Status status;
  std::thread call([&] { status = stub->Gather(&context, request, &response); });
  std::this_thread::sleep_for(std::chrono::milliseconds(700));
  context.TryCancel();
  call.join();
  EXPECT_EQ(status.error_code(), grpc::StatusCode::CANCELLED) << status.error_message();
  expect_work_stopped("cancelled Gather");
}

// A build whose only client leaves is cancelled and cleaned up
// (build_cancellation_test.cpp); the next client gets the scene built
// anew, and the daemon serves normally.
TEST_F(ClientLeaves, LeavingAnOpenSceneStreamKeepsTheBuildUsable) {
  auto channel = grpc::CreateChannel(daemon->address(), grpc::InsecureChannelCredentials());
  auto stub = v1::Pbgi::NewStub(channel);
  v1::OpenSceneRequest request;
  request.set_scene_path(kCornell.string());
  *request.mutable_build() = build_with(60000);
  {
    grpc::ClientContext context;
    auto reader = stub->OpenScene(&context, request);
    v1::OpenSceneEvent event;
    int progress_events = 0;
    while (progress_events < 3 && reader->Read(&event)) {
      if (event.has_progress()) ++progress_events;
    }
    ASSERT_EQ(progress_events, 3);
    context.TryCancel();
    while (reader->Read(&event)) {
    }
    EXPECT_EQ(reader->Finish().error_code(), grpc::StatusCode::CANCELLED);
  }
  PbgiClient client(daemon->address(), no_retry());
  const v1::SceneInfo info = client.open_scene(kCornell.string(), build_with(60000));
  EXPECT_GT(info.surfel_count(), 30000u);
  EXPECT_NO_THROW(client::render_frame(client, frame_request(info.scene_id(), 16, 8)));
  // Once built nothing runs for the departed client.
  EXPECT_GE(seconds_until_idle(std::chrono::seconds(5)), 0);
}

}  // namespace
}  // namespace pbgi::testing
