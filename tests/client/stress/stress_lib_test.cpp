// The pieces of pbgi stress that need no daemon: percentiles, the RSS
// reader and its growth measure, the health messages' wire format, the
// reports, and option checks.
#include "client/stress/health_check.h"
#include "client/stress/latency_summary.h"
#include "client/stress/replica_frame.h"
#include "client/stress/rss_sampler.h"
#include "client/stress/stress_report.h"
#include "client/stress/stress_runner.h"
#include "common/errors.h"
#include "tests/client/lib/fake_pbgi_server.h"

#include <gtest/gtest.h>

#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <thread>

namespace pbgi::stress {
namespace {

TEST(Latency, NearestRankPercentiles) {
  std::vector<double> v;
  for (int i = 100; i >= 1; --i) v.push_back(i);  // 1..100 shuffled order
  const LatencySummary s = summarize_latencies(v);
  EXPECT_EQ(s.count, 100u);
  EXPECT_EQ(s.min_ms, 1);
  EXPECT_EQ(s.max_ms, 100);
  EXPECT_EQ(s.p50_ms, 50);
  EXPECT_EQ(s.p95_ms, 95);
  EXPECT_EQ(s.p99_ms, 99);
  EXPECT_DOUBLE_EQ(s.mean_ms, 50.5);
  std::vector<double> one = {7};
  EXPECT_EQ(summarize_latencies(one).p99_ms, 7);
  std::vector<double> none;
  EXPECT_EQ(summarize_latencies(none).count, 0u);
  // A single slow call among 1000 shows at p99.9 only, not at p99.
  std::vector<double> tail(999, 1.0);
  tail.push_back(1000);
  std::sort(tail.begin(), tail.end());
  EXPECT_EQ(percentile(tail, 99), 1);
  EXPECT_EQ(percentile(tail, 100), 1000);
}

TEST(Rss, ReadsThisProcessAndSeesAnAllocation) {
  const uint64_t before = read_rss_bytes(getpid());
  EXPECT_GT(before, 1u << 20);
  std::vector<char> block(64 << 20, 1);  // touched: resident
  const uint64_t after = read_rss_bytes(getpid());
  EXPECT_GT(after, before + (48u << 20));
  EXPECT_EQ(block[12345], 1);
  EXPECT_THROW(read_rss_bytes(0x3fffffff), NotFound);
}

TEST(Rss, SamplerRecordsACurveAndWritesCsv) {
  RssSampler sampler(getpid(), std::chrono::milliseconds(10));
  std::this_thread::sleep_for(std::chrono::milliseconds(120));
  sampler.stop();
  const auto samples = sampler.samples();
  EXPECT_GE(samples.size(), 5u);
  for (size_t i = 1; i < samples.size(); ++i) EXPECT_GT(samples[i].seconds, samples[i - 1].seconds);
  EXPECT_GT(sampler.peak_bytes(), 0u);
  const auto path = std::filesystem::temp_directory_path() / ("rss-" + std::to_string(getpid()) + ".csv");
  write_rss_csv(samples, path);
  std::ifstream in(path);
  std::string header, row;
  std::getline(in, header);
  EXPECT_EQ(header, "seconds,rss_mib");
  size_t rows = 0;
  while (std::getline(in, row)) ++rows;
  EXPECT_EQ(rows, samples.size());
  std::filesystem::remove(path);
}

TEST(Rss, GrowthIgnoresWarmUpAndSeesALeak) {
  std::vector<RssSample> flat, leak;
  for (int i = 0; i < 40; ++i) {
    // Warm-up to 100 MiB in the first quarter, then flat / growing 1 MiB a sample.
    const double base = i < 10 ? 10.0 * i : 100.0;
    flat.push_back({double(i), uint64_t(base * (1 << 20))});
    leak.push_back({double(i), uint64_t((base + (i >= 10 ? i - 10 : 0)) * (1 << 20))});
  }
  EXPECT_NEAR(rss_growth_bytes(flat), 0.0, 1.0);
  EXPECT_GT(rss_growth_bytes(leak), 15.0 * (1 << 20));
  EXPECT_EQ(rss_growth_bytes({}), 0.0);
}

TEST(Health, WireFormat) {
  EXPECT_EQ(encode_health_request(""), "");
  EXPECT_EQ(encode_health_request("pbgi.v1.Pbgi"), std::string("\x0a\x0c") + "pbgi.v1.Pbgi");
  EXPECT_EQ(encode_health_request(std::string(200, 'a')).substr(0, 3), std::string("\x0a\xc8\x01"));
  EXPECT_EQ(decode_health_response(""), HealthStatus::Unknown);
  EXPECT_EQ(decode_health_response("\x08\x01"), HealthStatus::Serving);
  EXPECT_EQ(decode_health_response("\x08\x02"), HealthStatus::NotServing);
  // Unknown fields are skipped; a newer enum value reads as UNKNOWN.
  EXPECT_EQ(decode_health_response(std::string("\x12\x02hi\x08\x01", 6)), HealthStatus::Serving);
  EXPECT_EQ(decode_health_response("\x08\x09"), HealthStatus::Unknown);
  EXPECT_THROW(decode_health_response("\x08"), InvalidArgument);
  EXPECT_THROW(decode_health_response("\x12\x05x"), InvalidArgument);
  EXPECT_THROW(decode_health_response("\x0b"), InvalidArgument);
}

TEST(Health, NoDaemonIsUnreachable) {
  const HealthReply r = check_health("unix:/nonexistent/pbgid.sock", "", std::chrono::milliseconds(300));
  EXPECT_EQ(r.status, HealthStatus::Unreachable);
  EXPECT_FALSE(r.detail.empty());
}

TEST(Report, TextAndJsonCarryTheFigures) {
  StressResult r;
  r.scene_ids = {"abc"};
  r.camera = "/Camera";
  r.clients = 4;
  r.seconds = 10;
  r.requests = 103;
  r.ok = 100;
  r.pixels = 25600;
  r.errors_by_code = {{"UNAVAILABLE", 3}};
  r.error_samples = {"client 0: \"quoted\"\n"};
  r.requests_per_server = {103};
  std::vector<double> lat = {1, 2, 3};
  r.latency = summarize_latencies(lat);
  RssSummary rss = summarize_rss({{0, 100 << 20}, {1, 120 << 20}}, 110 << 20, "rss.csv");
  EXPECT_FALSE(rss.within_limit());
  const std::string text = format_stress_text(r, rss);
  EXPECT_NE(text.find("UNAVAILABLE x3"), std::string::npos) << text;
  EXPECT_NE(text.find("EXCEEDED"), std::string::npos) << text;
  EXPECT_NE(text.find("FAIL"), std::string::npos) << text;
  const std::string json = format_stress_json(r, rss);
  EXPECT_NE(json.find("\"passed\": false"), std::string::npos) << json;
  EXPECT_NE(json.find("\"errors\": 3"), std::string::npos) << json;
  EXPECT_NE(json.find("\"UNAVAILABLE\": 3"), std::string::npos) << json;
  EXPECT_NE(json.find("\\\"quoted\\\"\\n"), std::string::npos) << json;
  EXPECT_NE(json.find("\"peak_bytes\": 125829120"), std::string::npos) << json;
  r.errors_by_code.clear();
  r.requests = r.ok;
  EXPECT_TRUE(r.passed());
  EXPECT_NE(format_stress_text(r, std::nullopt).find("PASS"), std::string::npos);
}

TEST(Runner, RejectsMeaninglessOptions) {
  StressOptions o;
  EXPECT_THROW(run_stress(o), InvalidArgument);  // no server
  o.servers = {"unix:/nonexistent.sock"};
  o.clients = 0;
  EXPECT_THROW(run_stress(o), InvalidArgument);
  o.clients = 1;
  o.tile = 0;
  EXPECT_THROW(run_stress(o), InvalidArgument);
}

// A frame dealt over two replicas sums every tile statistic, camera samples
// and pixels included (its own copy of the summing left those two at 0),
// and puts each tile's pixels where the tile belongs.
TEST(ReplicaFrame, SumsEveryStatisticAndPlacesTiles) {
  auto render = [](auto*, const v1::RenderTileRequest* r, v1::RenderTileResponse* out) {
    return testing::coordinate_tile(r, out);
  };
  testing::FakePbgiServer a, b;
  a.service.render = render;
  b.service.render = render;
  client::PbgiClient ca(a.address()), cb(b.address());
  client::FrameRequest request;
  request.scene_id = std::string("scene");
  request.camera = "/Camera";
  request.width = 20;
  request.height = 12;
  request.tile_size = 8;
  const ReplicaFrame out = render_frame_replicated({&ca, &cb}, request);
  EXPECT_EQ(out.frame.stats.pixels(), 240u);
  EXPECT_EQ(out.frame.stats.camera_samples(), 960u);
  EXPECT_EQ(out.frame.stats.receivers(), 240u);
  EXPECT_EQ(out.frame.stats.nodes_visited(), 6u);  // one per tile
  EXPECT_GT(a.service.render_calls.load(), 0);
  EXPECT_GT(b.service.render_calls.load(), 0);
  for (uint32_t y = 0; y < 12; ++y) {
    for (uint32_t x = 0; x < 20; ++x) {
      const size_t i = size_t(y) * 20 + x;
      ASSERT_EQ(out.frame.beauty[3 * i], float(x));
      ASSERT_EQ(out.frame.beauty[3 * i + 1], float(y));
      ASSERT_EQ(out.frame.ao[i], float(x + 1000 * y));
    }
  }
}

// A scene without a camera is rendered through the auto camera, as by
// pbgi render (its own camera choice refused such a scene: "has 0 cameras").
TEST(Runner, SceneWithoutCameraUsesTheAutoCamera) {
  testing::FakePbgiServer server;
  server.service.open = [](auto*, const v1::OpenSceneRequest* r, grpc::ServerWriter<v1::OpenSceneEvent>* w) {
    v1::OpenSceneEvent e;
    e.mutable_ready()->set_scene_id("id");
    e.mutable_ready()->set_scene_path(r->scene_path());
    w->Write(e);
    return grpc::Status::OK;
  };
  std::atomic<int> auto_camera_tiles{0};
  server.service.render = [&](auto*, const v1::RenderTileRequest* r, v1::RenderTileResponse* out) {
    if (r->camera() == client::kAutoCamera) ++auto_camera_tiles;
    return testing::coordinate_tile(r, out);
  };
  StressOptions options;
  options.servers = {server.address()};
  options.scene = "asset.usda";
  options.clients = 1;
  options.width = options.height = options.tile = 8;
  options.duration = std::chrono::duration<double>(0.2);
  const StressResult result = run_stress(options, {});
  EXPECT_EQ(result.camera, client::kAutoCamera);
  EXPECT_GT(result.ok, 0u);
  EXPECT_EQ(result.ok, result.requests);
  EXPECT_GT(auto_camera_tiles.load(), 0);
}

}  // namespace
}  // namespace pbgi::stress
