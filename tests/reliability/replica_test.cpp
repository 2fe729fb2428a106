// The multi-replica story on one machine: two daemons on one cache
// directory serve the same content-addressed page set (built once, by the
// first); a frame whose tiles are dealt round robin over both is
// bit-identical to the frame one daemon renders alone; when one replica
// dies its tiles fail over to the other. Also the health probe that
// containers and Kubernetes run (`pbgi health`).
#include "client/stress/health_check.h"
#include "client/stress/replica_frame.h"
#include "tests/reliability/reliability_env.h"

namespace fs = std::filesystem;

namespace pbgi::testing {
namespace {

using client::PbgiClient;

TEST(Replicas, TwoDaemonsOnOnePageSetRenderIdenticalFrames) {
  TempDir tmp;
  const fs::path cache = tmp / "cache";
  auto a = start_daemon(tmp, "a", cache);
  auto b = start_daemon(tmp, "b", cache);
  PbgiClient ca(a->address()), cb(b->address());
  const v1::SceneInfo ia = ca.open_scene(kCornell.string(), build_with(20000));
  const v1::SceneInfo ib = cb.open_scene(kCornell.string(), build_with(20000));
  EXPECT_FALSE(ia.reused_cache());
  EXPECT_TRUE(ib.reused_cache()) << "the second replica reads the first one's page set";
  EXPECT_FALSE(ia.reused_ingest());
  EXPECT_TRUE(ib.reused_ingest()) << "the second replica reads the first one's stored ingest";
  ASSERT_EQ(ia.scene_id(), ib.scene_id()) << "scene ids are content addresses";
  EXPECT_EQ(published_page_sets(cache).size(), 1u);

  const client::FrameRequest request = frame_request(ia.scene_id(), 32, 8);
  const client::Frame alone = client::render_frame(ca, request);
  const stress::ReplicaFrame spread = stress::render_frame_replicated({&ca, &cb}, request);
  ASSERT_EQ(spread.tiles_per_replica.size(), 2u);
  EXPECT_EQ(spread.tiles_per_replica[0], 8u);  // 16 tiles dealt round robin
  EXPECT_EQ(spread.tiles_per_replica[1], 8u);
  EXPECT_EQ(spread.failovers, 0u);
  EXPECT_TRUE(frames_identical(alone, spread.frame));

  // One replica dies: its tiles go to the other, the frame is the same.
  EXPECT_EQ(b->kill9(), 128 + 9);
  const stress::ReplicaFrame degraded = stress::render_frame_replicated({&ca, &cb}, request);
  EXPECT_EQ(degraded.tiles_per_replica[0], 16u);
  EXPECT_EQ(degraded.failovers, 8u);
  EXPECT_TRUE(frames_identical(alone, degraded.frame));
  EXPECT_EQ(a->terminate(), 0) << a->log();
}

// Both replicas asked for a scene nobody has built yet, at the same time:
// both build it, one publishes first; the other must still serve it.
// (Regression: the loser failed with INVALID_ARGUMENT "page set directory
// ... already exists" in about half the runs; it now opens the published
// set, server/engine/scene_session.cpp build_or_join.)
TEST(Replicas, ConcurrentFirstOpensOnASharedCacheBothSucceed) {
  TempDir tmp;
  const fs::path cache = tmp / "cache";
  auto a = start_daemon(tmp, "a", cache);
  auto b = start_daemon(tmp, "b", cache);
  v1::SceneInfo ia, ib;
  std::string ea, eb;
  std::thread ta([&] {
    try {
      ia = PbgiClient(a->address()).open_scene(kCornell.string(), build_with(20000));
    } catch (const std::exception& e) {
      ea = e.what();
    }
  });
  std::thread tb([&] {
    try {
      ib = PbgiClient(b->address()).open_scene(kCornell.string(), build_with(20000));
    } catch (const std::exception& e) {
      eb = e.what();
    }
  });
  ta.join();
  tb.join();
  EXPECT_EQ(ea, "");
  EXPECT_EQ(eb, "");
  EXPECT_EQ(ia.scene_id(), ib.scene_id());
  EXPECT_EQ(published_page_sets(cache).size(), 1u);
  EXPECT_TRUE(entries_named(cache, ".tmp-").empty());
}

TEST(Health, ProbeReportsServingAndUnreachable) {
  TempDir tmp;
  auto d = start_daemon(tmp, "d", tmp / "cache");
  EXPECT_EQ(stress::check_health(d->address(), "", std::chrono::seconds(5)).status,
            stress::HealthStatus::Serving);
  EXPECT_EQ(stress::check_health(d->address(), "pbgi.v1.Pbgi", std::chrono::seconds(5)).status,
            stress::HealthStatus::Serving);
  EXPECT_EQ(stress::check_health(d->address(), "no.such.Service", std::chrono::seconds(5)).status,
            stress::HealthStatus::ServiceUnknown);

  // The CLI: exit 0 when serving, 1 otherwise (what probes look at).
  const CommandResult ok = run_command(kPbgi.string() + " health --server " + d->address());
  EXPECT_EQ(ok.status, 0) << ok.out;
  EXPECT_NE(ok.out.find("SERVING"), std::string::npos) << ok.out;
  const std::string address = d->address();
  EXPECT_EQ(d->terminate(), 0);
  EXPECT_EQ(stress::check_health(address, "", std::chrono::milliseconds(500)).status,
            stress::HealthStatus::Unreachable);
  const CommandResult down =
      run_command(kPbgi.string() + " health --timeout 0.5 --server " + address);
  EXPECT_EQ(down.status, 1) << down.out;
  EXPECT_NE(down.out.find("UNREACHABLE"), std::string::npos) << down.out;
}

}  // namespace
}  // namespace pbgi::testing
