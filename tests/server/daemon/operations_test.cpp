// Operations of pbgid in-process: the Prometheus endpoint (request counts
// and latency histograms by RPC and status, cache and memory gauges) and
// JSON logs that stay valid JSON whatever the message holds.
#include "server/daemon/daemon.h"

#include "client/lib/pbgi_client.h"
#include "tests/server/service/fake_sessions.h"
#include "tests/server/service/temp_dir.h"

#include <gtest/gtest.h>
#include <spdlog/spdlog.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <fstream>

namespace fs = std::filesystem;

namespace pbgi::daemon {
namespace {

// One HTTP/1.0 request to 127.0.0.1:port (with extra header lines); the
// whole response.
std::string http_get(uint16_t port, const std::string& path, const std::string& headers = "") {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(port);
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0) {
    ::close(fd);
    return "connect failed";
  }
  const std::string request = "GET " + path + " HTTP/1.0\r\n" + headers + "\r\n";
  ::send(fd, request.data(), request.size(), 0);
  std::string response;
  char buffer[4096];
  for (ssize_t n; (n = ::recv(fd, buffer, sizeof buffer, 0)) > 0;) response.append(buffer, n);
  ::close(fd);
  return response;
}

TEST(DaemonOperations, WithABearerTokenMetricsNeedIt) {
  testing::TempDir tmp;
  DaemonOptions options;
  options.cache_dir = (tmp.path() / "cache").string();
  options.log_level = "error";
  options.metrics_listen = "127.0.0.1:0";
  options.auth_token = "metrics-token";
  Daemon daemon(options, [](const fs::path& path, const OpenOptions&, const service::StageSelection&,
                            const StageProgress&, const std::function<bool()>&) {
    return testing::fake_session(path.string(), "id");
  });
  daemon.start();
  EXPECT_EQ(http_get(daemon.metrics_port(), "/metrics").rfind("HTTP/1.0 401", 0), 0u);
  EXPECT_EQ(http_get(daemon.metrics_port(), "/metrics", "Authorization: Bearer wrong\r\n").rfind("HTTP/1.0 401", 0),
            0u);
  EXPECT_EQ(http_get(daemon.metrics_port(), "/metrics", "authorization: Bearer metrics-token\r\n")
                .rfind("HTTP/1.0 200 OK", 0),
            0u);
  EXPECT_EQ(http_get(daemon.metrics_port(), "/healthz").rfind("HTTP/1.0 200 OK", 0), 0u) << "probes need no token";
}

TEST(DaemonOperations, PrometheusEndpointCountsRequestsByRpcAndStatus) {
  testing::TempDir tmp;
  fs::create_directories(tmp.path() / "scenes");
  std::ofstream(tmp.path() / "scenes" / "a.usda") << "#usda 1.0\n";
  DaemonOptions options;
  options.scene_roots = {(tmp.path() / "scenes").string()};
  options.cache_dir = (tmp.path() / "cache").string();
  options.log_level = "error";
  options.metrics_listen = "127.0.0.1:0";
  Daemon daemon(options, [](const fs::path& path, const OpenOptions&,
                            const service::StageSelection&, const StageProgress&, const std::function<bool()>&) {
    return testing::fake_session(path.string(), "id-a");
  });
  daemon.start();
  ASSERT_GT(daemon.metrics_port(), 0);

  client::PbgiClient client(daemon.address());
  client.open_scene("a.usda");
  client.list_scenes();
  client.list_scenes();
  EXPECT_THROW(client.unload_scene("nope"), client::RpcError);

  const std::string metrics = http_get(daemon.metrics_port(), "/metrics");
  EXPECT_EQ(metrics.rfind("HTTP/1.0 200 OK\r\n", 0), 0u) << metrics;
  EXPECT_NE(metrics.find("text/plain; version=0.0.4"), std::string::npos);
  for (const char* line : {"pbgi_requests_total{rpc=\"ListScenes\",code=\"OK\"} 2\n",
                           "pbgi_requests_total{rpc=\"OpenScene\",code=\"OK\"} 1\n",
                           "pbgi_requests_total{rpc=\"UnloadScene\",code=\"NOT_FOUND\"} 1\n",
                           "pbgi_request_duration_seconds_bucket{rpc=\"ListScenes\",le=\"+Inf\"} 2\n",
                           "pbgi_request_duration_seconds_count{rpc=\"ListScenes\"} 2\n",
                           "# TYPE pbgi_request_duration_seconds histogram\n", "pbgi_scenes_open 1\n",
                           // The cache gets the 2 GiB budget less the 64 MiB request reserve
                           // (nothing is charged: the fake scene has no memory charge).
                           "pbgi_cache_hits_total 0\n", "pbgi_cache_budget_bytes 2080374784\n",
                           "# TYPE pbgi_cache_read_bytes_total counter\n",
                           // The whole budget and who holds it (docs/memory-budget.md).
                           "pbgi_memory_budget_bytes 2147483648\n", "pbgi_memory_request_reserve_bytes 67108864\n",
                           "pbgi_memory_page_cache_floor_bytes 33554432\n",
                           "pbgi_memory_charged_bytes{kind=\"scenes\"} 0\n",
                           "pbgi_memory_charged_bytes{kind=\"reading\"} 0\n",
                           "pbgi_memory_charged_bytes{kind=\"builds\"} 0\n", "# TYPE pbgi_memory_refusals_total counter\n",
                           "pbgi_memory_refusals_total 0\n"}) {
    EXPECT_NE(metrics.find(line), std::string::npos) << "missing: " << line << metrics;
  }
  EXPECT_EQ(metrics.find("pbgi_resident_memory_bytes 0\n"), std::string::npos)
      << "the RSS is measured";
  EXPECT_NE(metrics.find("pbgi_resident_memory_bytes "), std::string::npos);
  EXPECT_NE(http_get(daemon.metrics_port(), "/healthz").find("\r\n\r\nok"), std::string::npos);
  EXPECT_EQ(http_get(daemon.metrics_port(), "/other").rfind("HTTP/1.0 404", 0), 0u);
}

TEST(DaemonOperations, JsonLogsEscapeTheMessage) {
  ::testing::internal::CaptureStderr();
  configure_logging("info", "json");
  spdlog::info("scene \"a\\b\"\nline two");
  spdlog::default_logger()->flush();
  const std::string out = ::testing::internal::GetCapturedStderr();
  configure_logging("warn");
  EXPECT_EQ(out.rfind("{\"time\":\"", 0), 0u) << out;
  EXPECT_NE(out.find("\"level\":\"info\""), std::string::npos) << out;
  EXPECT_NE(out.find(R"("msg":"scene \"a\\b\"\nline two"})"), std::string::npos) << out;
  EXPECT_EQ(std::count(out.begin(), out.end(), '\n'), 1) << "one line per record: " << out;
}

}  // namespace
}  // namespace pbgi::daemon
