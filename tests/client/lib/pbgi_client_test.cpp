// PbgiClient against a fake server: errors carry the server's status and
// message, UNAVAILABLE is retried (but never a started OpenScene), deadlines
// are enforced, progress is relayed, malformed responses are refused.
#include "client/lib/packed_floats.h"
#include "client/lib/pbgi_client.h"
#include "tests/client/lib/fake_pbgi_server.h"

#include <gtest/gtest.h>

#include <atomic>
#include <filesystem>
#include <mutex>
#include <thread>

namespace pbgi::client {
namespace {

using testing::FakePbgiServer;

ClientOptions fast_retries(int attempts) {
  ClientOptions o;
  o.max_attempts = attempts;
  o.initial_backoff = std::chrono::milliseconds(5);
  o.max_backoff = std::chrono::milliseconds(20);
  o.call_deadline = std::chrono::seconds(10);
  return o;
}

TEST(PbgiClient, ServerErrorBecomesRpcErrorWithItsMessage) {
  FakePbgiServer server;
  server.service.gather = [](auto*, const v1::GatherRequest* r, auto*) {
    return grpc::Status(grpc::StatusCode::NOT_FOUND, "scene_id '" + r->scene_id() + "' is not open");
  };
  PbgiClient client(server.address(), fast_retries(3));
  try {
    client.gather("abc123", {{0, 0, 0}}, {{0, 1, 0}});
    FAIL() << "expected RpcError";
  } catch (const RpcError& e) {
    EXPECT_EQ(e.code(), grpc::StatusCode::NOT_FOUND);
    EXPECT_EQ(e.server_message(), "scene_id 'abc123' is not open");
    EXPECT_NE(std::string(e.what()).find("Gather: NOT_FOUND: scene_id 'abc123'"), std::string::npos)
        << e.what();
  }
  EXPECT_EQ(server.service.gather_calls, 1) << "only UNAVAILABLE is retried";
}

TEST(PbgiClient, RpcErrorIsAPbgiError) {
  FakePbgiServer server;
  server.service.render = [](auto*, auto*, auto*) {
    return grpc::Status(grpc::StatusCode::OUT_OF_RANGE, "tile outside");
  };
  PbgiClient client(server.address());
  EXPECT_THROW(client.render_tile(v1::RenderTileRequest()), pbgi::Error);
}

TEST(PbgiClient, RetriesUnavailableThenSucceeds) {
  FakePbgiServer server;
  std::atomic<int> calls{0};
  server.service.gather = [&](auto*, const v1::GatherRequest* r, v1::GatherResponse* out) {
    if (++calls <= 2) return grpc::Status(grpc::StatusCode::UNAVAILABLE, "warming up");
    const size_t n = r->positions().size() / 12;
    out->set_irradiance(std::string(n * 12, '\0'));
    out->set_ao(std::string(n * 4, '\0'));
    return grpc::Status::OK;
  };
  PbgiClient client(server.address(), fast_retries(5));
  const GatherOutput result = client.gather("s", {{0, 0, 0}, {1, 0, 0}}, {{0, 1, 0}, {0, 1, 0}});
  EXPECT_EQ(calls, 3);
  EXPECT_EQ(result.irradiance.size(), 2u);
  EXPECT_EQ(result.ao.size(), 2u);
}

TEST(PbgiClient, RetriesOverloadedAfterTheServersHintOnly) {
  FakePbgiServer server;
  std::atomic<int> calls{0};
  std::vector<std::chrono::steady_clock::time_point> times;
  std::mutex mutex;
  server.service.gather = [&](grpc::ServerContext* context, const v1::GatherRequest*,
                              v1::GatherResponse* out) {
    {
      std::lock_guard lock(mutex);
      times.push_back(std::chrono::steady_clock::now());
    }
    if (++calls <= 2) {
      context->AddTrailingMetadata("retry-after-ms", "60");
      return grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED, "overloaded");
    }
    const float zeros[4] = {};
    out->set_irradiance(std::string(reinterpret_cast<const char*>(zeros), 12));
    out->set_ao(std::string(reinterpret_cast<const char*>(zeros), 4));
    return grpc::Status::OK;
  };
  PbgiClient client(server.address(), fast_retries(5));
  EXPECT_EQ(client.gather("s", {{0, 0, 0}}, {{0, 1, 0}}).irradiance.size(), 1u);
  ASSERT_EQ(calls, 3);
  for (int i = 1; i < 3; ++i) {
    EXPECT_GE(times[i] - times[i - 1], std::chrono::milliseconds(55))
        << "waited at least the hint (backoff alone is <= 20 ms)";
  }

  // Without a hint (e.g. a message too large), RESOURCE_EXHAUSTED is final.
  calls = 0;
  server.service.gather = [&](auto*, auto*, auto*) {
    ++calls;
    return grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED, "too big");
  };
  EXPECT_THROW(client.gather("s", {{0, 0, 0}}, {{0, 1, 0}}), RpcError);
  EXPECT_EQ(calls, 1);
  // Nor is it retried when the caller opts out.
  ClientOptions no_retry = fast_retries(5);
  no_retry.retry_overloaded = false;
  calls = 0;
  server.service.gather = [&](grpc::ServerContext* context, auto*, auto*) {
    ++calls;
    context->AddTrailingMetadata("retry-after-ms", "10");
    return grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED, "overloaded");
  };
  EXPECT_THROW(PbgiClient(server.address(), no_retry).gather("s", {{0, 0, 0}}, {{0, 1, 0}}),
               RpcError);
  EXPECT_EQ(calls, 1);
}

TEST(PbgiClient, SendsTheBearerToken) {
  FakePbgiServer server;
  std::string seen;
  server.service.gather = [&](grpc::ServerContext* context, auto*, auto*) {
    const auto it = context->client_metadata().find("authorization");
    if (it != context->client_metadata().end()) seen.assign(it->second.data(), it->second.size());
    return grpc::Status(grpc::StatusCode::NOT_FOUND, "");
  };
  ClientOptions o = fast_retries(1);
  o.token = "tok";
  EXPECT_THROW(PbgiClient(server.address(), o).gather("s", {{0, 0, 0}}, {{0, 1, 0}}), RpcError);
  EXPECT_EQ(seen, "Bearer tok");
  o.tls_ca_file = "/nonexistent/ca.pem";
  EXPECT_THROW(PbgiClient(server.address(), o), IoError) << "a missing CA file is an error";
}

TEST(PbgiClient, GivesUpAfterMaxAttempts) {
  FakePbgiServer server;
  server.service.gather = [](auto*, auto*, auto*) {
    return grpc::Status(grpc::StatusCode::UNAVAILABLE, "still down");
  };
  PbgiClient client(server.address(), fast_retries(3));
  try {
    client.gather_raw(v1::GatherRequest());
    FAIL() << "expected RpcError";
  } catch (const RpcError& e) {
    EXPECT_EQ(e.code(), grpc::StatusCode::UNAVAILABLE);
  }
  EXPECT_EQ(server.service.gather_calls, 3);
}

TEST(PbgiClient, NoDaemonIsUnavailable) {
  char pattern[] = "/tmp/pbgi-nodaemon-XXXXXX";
  ASSERT_NE(mkdtemp(pattern), nullptr);
  const std::string address = std::string("unix:") + pattern + "/missing.sock";
  PbgiClient client(address, fast_retries(2));
  try {
    client.list_scenes();
    FAIL() << "expected RpcError";
  } catch (const RpcError& e) {
    EXPECT_EQ(e.code(), grpc::StatusCode::UNAVAILABLE);
  }
  std::filesystem::remove_all(pattern);
}

TEST(PbgiClient, DeadlineExceeded) {
  FakePbgiServer server;
  server.service.render = [](grpc::ServerContext* context, auto*, auto*) {
    // Blocks until the client's deadline cancels the call.
    while (!context->IsCancelled()) std::this_thread::sleep_for(std::chrono::milliseconds(5));
    return grpc::Status(grpc::StatusCode::CANCELLED, "cancelled");
  };
  ClientOptions options = fast_retries(3);
  options.call_deadline = std::chrono::milliseconds(200);
  PbgiClient client(server.address(), options);
  try {
    client.render_tile_raw(v1::RenderTileRequest());
    FAIL() << "expected RpcError";
  } catch (const RpcError& e) {
    EXPECT_EQ(e.code(), grpc::StatusCode::DEADLINE_EXCEEDED);
  }
}

TEST(PbgiClient, OpenSceneRelaysProgressAndReturnsInfo) {
  FakePbgiServer server;
  server.service.open = [](auto*, const v1::OpenSceneRequest* r,
                           grpc::ServerWriter<v1::OpenSceneEvent>* writer) {
    for (float f : {0.f, 0.5f, 1.f}) {
      v1::OpenSceneEvent e;
      e.mutable_progress()->set_stage("surfels");
      e.mutable_progress()->set_fraction(f);
      writer->Write(e);
    }
    v1::OpenSceneEvent ready;
    ready.mutable_ready()->set_scene_id("id-1");
    ready.mutable_ready()->set_scene_path(r->scene_path());
    ready.mutable_ready()->set_surfel_count(r->build().target_surfels());
    writer->Write(ready);
    return grpc::Status::OK;
  };
  PbgiClient client(server.address());
  std::vector<float> fractions;
  v1::BuildOptions build;
  build.set_target_surfels(1234);
  const v1::SceneInfo info = client.open_scene(
      "/scenes/a.usda", build,
      [&](const std::string& stage, float f) {
        EXPECT_EQ(stage, "surfels");
        fractions.push_back(f);
      });
  EXPECT_EQ(fractions, (std::vector<float>{0.f, 0.5f, 1.f}));
  EXPECT_EQ(info.scene_id(), "id-1");
  EXPECT_EQ(info.scene_path(), "/scenes/a.usda");
  EXPECT_EQ(info.surfel_count(), 1234u);
}

TEST(PbgiClient, OpenSceneNotRetriedOnceStarted) {
  FakePbgiServer server;
  server.service.open = [](auto*, auto*, grpc::ServerWriter<v1::OpenSceneEvent>* writer) {
    v1::OpenSceneEvent e;
    e.mutable_progress()->set_stage("ingest");
    writer->Write(e);
    return grpc::Status(grpc::StatusCode::UNAVAILABLE, "went away mid-open");
  };
  PbgiClient client(server.address(), fast_retries(5));
  EXPECT_THROW(client.open_scene("/a.usda"), RpcError);
  EXPECT_EQ(server.service.open_calls, 1);
}

TEST(PbgiClient, OpenSceneWithoutReadyIsAnError) {
  FakePbgiServer server;
  server.service.open = [](auto*, auto*, auto*) { return grpc::Status::OK; };
  PbgiClient client(server.address());
  EXPECT_THROW(client.open_scene("/a.usda"), RpcError);
}

TEST(PbgiClient, RefusesTileWithWrongAovSize) {
  FakePbgiServer server;
  server.service.render = [](auto*, const v1::RenderTileRequest* r, v1::RenderTileResponse* out) {
    *out->mutable_tile() = r->tile();
    const size_t pixels = size_t(r->tile().x1() - r->tile().x0()) * (r->tile().y1() - r->tile().y0());
    const std::string rgb(pixels * 12, '\0');
    out->set_beauty(rgb);
    out->set_direct(rgb);
    out->set_indirect(rgb.substr(4));  // one float short
    out->set_albedo(rgb);
    out->set_ao(std::string(pixels * 4, '\0'));
    return grpc::Status::OK;
  };
  PbgiClient client(server.address());
  v1::RenderTileRequest request;
  request.mutable_tile()->set_x1(4);
  request.mutable_tile()->set_y1(2);
  try {
    client.render_tile(request);
    FAIL() << "expected CorruptionError";
  } catch (const CorruptionError& e) {
    EXPECT_NE(std::string(e.what()).find("RenderTileResponse.indirect"), std::string::npos);
  }
}

TEST(PbgiClient, GatherChecksSizesBeforeSending) {
  FakePbgiServer server;
  PbgiClient client(server.address());
  EXPECT_THROW(client.gather("s", {{0, 0, 0}}, {}), InvalidArgument);
  EXPECT_EQ(server.service.gather_calls, 0);
}

TEST(PbgiClient, NormalizesAddressesAndScenePaths) {
  EXPECT_EQ(normalize_address("/tmp/x.sock"), "unix:/tmp/x.sock");
  EXPECT_EQ(normalize_address("unix:/tmp/x.sock"), "unix:/tmp/x.sock");
  EXPECT_EQ(normalize_address("localhost:5000"), "localhost:5000");
  // An existing local file goes as an absolute path, anything else as given.
  const std::string here = std::filesystem::path(PBGI_TEST_SOURCE_DIR) / "CMakeLists.txt";
  EXPECT_EQ(scene_request_path(here), here);
  EXPECT_EQ(scene_request_path("no/such/scene.usda"), "no/such/scene.usda");
}

}  // namespace
}  // namespace pbgi::client
