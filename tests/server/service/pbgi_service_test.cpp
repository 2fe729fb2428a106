// The handlers over an in-process channel with a fake opener: every bad
// request gets its own status code and a message naming what is wrong,
// and the service keeps serving afterwards.
#include "server/service/pbgi_service.h"

#include "common/errors.h"
#include "server/service/prometheus_text.h"
#include "storage/cache/page_cache.h"
#include "tests/server/service/fake_sessions.h"
#include "tests/server/service/temp_dir.h"

#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <cstring>
#include <fstream>
#include <limits>
#include <mutex>
#include <vector>

namespace fs = std::filesystem;

namespace pbgi::service {
namespace {

class PbgiServiceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    root = tmp.path() / "scenes";
    fs::create_directories(root);
    std::ofstream(root / "a.usda") << "#usda 1.0\n";
    std::ofstream(root / "bad.usda") << "not usd\n";
    std::ofstream(root / "lit.usda") << "#usda 1.0\n";
    auto registry = std::make_shared<SceneRegistry>(
        [this](const fs::path& path, const OpenOptions& options, const StageSelection& selection,
               const StageProgress& progress, const std::function<bool()>&) -> std::shared_ptr<SceneSession> {
          int n;
          {
            // The handler runs on a gRPC thread; the test reads on its own
            // after the call, ordered only through gRPC's core, which TSan
            // cannot see: the lock makes the hand-off explicit.
            std::lock_guard lock(record_mutex);
            n = ++record_.opens;
            record_.last_open = options;
            record_.last_selection = selection;
          }
          if (path.filename() == "bad.usda") {
            throw SceneError("'" + path.string() + "': not a USD layer");
          }
          progress("ingest", 0.f);
          progress("ingest", 1.f);
          progress("tree", 1.f);
          if (path.filename() == "lit.usda") {
            return testing::lit_session(path.string(), "scene-" + std::to_string(n),
                                        tmp.path() / ("pages-" + std::to_string(n)));
          }
          return testing::fake_session(path.string(), "scene-" + std::to_string(n));
        });
    ServiceOptions options;
    options.defaults.open.surfels.target_surfels = 777;
    options.limits.max_tile_pixels = 64 * 64;
    service = std::make_unique<PbgiService>(options, SceneRoots({root}), registry);
    grpc::ServerBuilder builder;
    builder.RegisterService(service.get());
    server = builder.BuildAndStart();
    stub = v1::Pbgi::NewStub(server->InProcessChannel(grpc::ChannelArguments()));
  }
  void TearDown() override {
    server->Shutdown();
    server->Wait();
  }

  grpc::Status open(const std::string& path, std::vector<v1::OpenSceneEvent>* events = nullptr,
                    const v1::BuildOptions& build = {}) {
    grpc::ClientContext context;
    v1::OpenSceneRequest request;
    request.set_scene_path(path);
    *request.mutable_build() = build;
    auto reader = stub->OpenScene(&context, request);
    v1::OpenSceneEvent event;
    while (reader->Read(&event)) {
      if (events) events->push_back(event);
    }
    return reader->Finish();
  }
  std::string open_id() {
    std::vector<v1::OpenSceneEvent> events;
    EXPECT_TRUE(open("a.usda", &events).ok());
    return events.empty() ? "" : events.back().ready().scene_id();
  }
  grpc::Status render(const v1::RenderTileRequest& request) {
    grpc::ClientContext context;
    v1::RenderTileResponse response;
    return stub->RenderTile(&context, request, &response);
  }
  grpc::Status gather(const v1::GatherRequest& request) {
    grpc::ClientContext context;
    v1::GatherResponse response;
    return stub->Gather(&context, request, &response);
  }
  v1::RenderTileRequest tile_request(const std::string& id) {
    v1::RenderTileRequest r;
    r.set_scene_id(id);
    r.set_camera("/Camera");
    r.set_image_width(64);
    r.set_image_height(48);
    r.mutable_tile()->set_x0(32);
    r.mutable_tile()->set_y0(32);
    r.mutable_tile()->set_x1(64);
    r.mutable_tile()->set_y1(48);
    return r;
  }
  static bool mentions(const grpc::Status& s, const std::string& text) {
    return s.error_message().find(text) != std::string::npos;
  }

  testing::TempDir tmp;
  fs::path root;
  // What the fake opener saw, read through record().
  struct OpenRecord {
    int opens = 0;
    OpenOptions last_open;
    StageSelection last_selection;
  };
  OpenRecord record() {
    std::lock_guard lock(record_mutex);
    return record_;
  }
  std::mutex record_mutex;
  OpenRecord record_;
  std::unique_ptr<PbgiService> service;
  std::unique_ptr<grpc::Server> server;
  std::unique_ptr<v1::Pbgi::Stub> stub;
};

TEST_F(PbgiServiceTest, OpenSceneStreamsProgressThenInfo) {
  std::vector<v1::OpenSceneEvent> events;
  ASSERT_TRUE(open("a.usda", &events).ok());
  ASSERT_GE(events.size(), 2u);
  EXPECT_TRUE(events.front().has_progress());
  EXPECT_EQ(events.front().progress().stage(), "ingest");
  const v1::SceneInfo& info = events.back().ready();
  EXPECT_EQ(info.scene_id(), "scene-1");
  EXPECT_EQ(info.scene_path(), (fs::canonical(root) / "a.usda").string());
  EXPECT_EQ(info.surfel_count(), 1000u);
  ASSERT_EQ(info.cameras_size(), 1);
  EXPECT_EQ(info.cameras(0), "/Camera");
  EXPECT_EQ(info.warnings_size(), 1);
  EXPECT_EQ(record().last_open.surfels.target_surfels, 777u)
      << "unset build option takes the default";

  // The same scene by its absolute path is the same session.
  ASSERT_TRUE(open((root / "a.usda").string()).ok());
  EXPECT_EQ(record().opens, 1);
  grpc::ClientContext context;
  v1::ListScenesResponse list;
  ASSERT_TRUE(stub->ListScenes(&context, v1::ListScenesRequest(), &list).ok());
  ASSERT_EQ(list.scenes_size(), 1);
  EXPECT_EQ(list.scenes(0).scene_id(), "scene-1");

  // Other build options: another session.
  v1::BuildOptions build;
  build.set_target_surfels(5000);
  ASSERT_TRUE(open("a.usda", nullptr, build).ok());
  EXPECT_EQ(record().opens, 2);
  EXPECT_EQ(record().last_open.surfels.target_surfels, 5000u);
}

TEST_F(PbgiServiceTest, OpenSceneErrors) {
  grpc::Status s = open("missing.usda");
  EXPECT_EQ(s.error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_TRUE(mentions(s, "missing.usda")) << s.error_message();

  s = open("/etc/passwd");
  EXPECT_EQ(s.error_code(), grpc::StatusCode::PERMISSION_DENIED);
  EXPECT_TRUE(mentions(s, "/etc/passwd")) << s.error_message();

  s = open("../../../etc/passwd");
  EXPECT_EQ(s.error_code(), grpc::StatusCode::PERMISSION_DENIED);

  s = open("bad.usda");
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_TRUE(mentions(s, "not a USD layer")) << s.error_message();

  v1::BuildOptions build;
  build.set_leaf_size(1000000);
  s = open("a.usda", nullptr, build);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << s.error_message();

  EXPECT_FALSE(open_id().empty()) << "still serving after the errors";
}

TEST_F(PbgiServiceTest, GatherRequestErrors) {
  const std::string id = open_id();
  v1::GatherRequest request;
  request.set_scene_id(id);
  request.set_positions(std::string(13, '\0'));
  request.set_normals(std::string(12, '\0'));
  grpc::Status s = gather(request);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_TRUE(mentions(s, "positions")) << s.error_message();
  EXPECT_TRUE(mentions(s, id)) << "names the scene: " << s.error_message();

  request.set_positions(std::string(24, '\0'));
  s = gather(request);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_TRUE(mentions(s, "normals")) << s.error_message();

  request.set_scene_id("no-such-scene");
  const float up[3] = {0, 1, 0};
  request.set_positions(std::string(12, '\0'));
  request.set_normals(std::string(reinterpret_cast<const char*>(up), sizeof(up)));
  s = gather(request);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_TRUE(mentions(s, "no-such-scene")) << s.error_message();
}

// A bad interpolation tolerance is refused on the Gather path too (it was
// ignored there while Gather gathered every receiver).
TEST_F(PbgiServiceTest, GatherRefusesBadInterpolationOptions) {
  std::vector<v1::OpenSceneEvent> events;
  ASSERT_TRUE(open("lit.usda", &events).ok());  // a real tree: the request could be served
  const std::string id = events.back().ready().scene_id();
  const float up[3] = {0, 0, 1};
  v1::GatherRequest request;
  request.set_scene_id(id);
  request.set_positions(std::string(12, '\0'));
  request.set_normals(std::string(reinterpret_cast<const char*>(up), sizeof(up)));
  for (const float t : {-0.1f, 0.f, 1.5f, std::numeric_limits<float>::quiet_NaN()}) {
    request.mutable_options()->set_interpolation_tolerance(t);
    const grpc::Status s = gather(request);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << "tolerance " << t;
    EXPECT_TRUE(mentions(s, "interpolation_tolerance")) << s.error_message();
  }
  request.mutable_options()->clear_interpolation_tolerance();
  request.mutable_options()->set_interpolation(static_cast<v1::GatherOptions::Interpolation>(9));
  const grpc::Status s = gather(request);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_TRUE(mentions(s, "GatherOptions.interpolation")) << s.error_message();
}

// By default Gather gathers a subset of a dense grid of receivers under a
// lit ceiling and interpolates the rest within the tolerance; the stats
// say how many it gathered of how many were sent. OFF gathers them all.
TEST_F(PbgiServiceTest, GatherInterpolatesDenseReceiversAndSaysHowManyItGathered) {
  std::vector<v1::OpenSceneEvent> events;
  ASSERT_TRUE(open("lit.usda", &events).ok());
  constexpr int kSide = 24;
  std::vector<float> positions, normals;
  for (int j = 0; j < kSide; ++j) {
    for (int i = 0; i < kSide; ++i) {
      positions.insert(positions.end(), {-0.6f + 1.2f * (i + 0.5f) / kSide, -0.6f + 1.2f * (j + 0.5f) / kSide, 0.f});
      normals.insert(normals.end(), {0.f, 0.f, 1.f});
    }
  }
  v1::GatherRequest request;
  request.set_scene_id(events.back().ready().scene_id());
  request.set_positions(std::string(reinterpret_cast<const char*>(positions.data()), positions.size() * sizeof(float)));
  request.set_normals(std::string(reinterpret_cast<const char*>(normals.data()), normals.size() * sizeof(float)));
  auto run = [&](v1::GatherResponse* response) {
    grpc::ClientContext context;
    const grpc::Status s = stub->Gather(&context, request, response);
    ASSERT_TRUE(s.ok()) << s.error_message();
    ASSERT_EQ(response->irradiance().size(), 3 * sizeof(float) * kSide * kSide);
  };
  v1::GatherResponse interpolated, full;
  run(&interpolated);
  request.mutable_options()->set_interpolation(v1::GatherOptions::INTERPOLATION_OFF);
  run(&full);
  constexpr uint64_t kReceivers = kSide * kSide;
  EXPECT_EQ(interpolated.stats().requested_receivers(), kReceivers);
  EXPECT_EQ(full.stats().requested_receivers(), kReceivers);
  EXPECT_EQ(full.stats().receivers(), kReceivers);
  EXPECT_GT(interpolated.stats().receivers(), 0u);
  EXPECT_LT(interpolated.stats().receivers(), kReceivers / 4);
  std::vector<float> a(3 * kReceivers), b(3 * kReceivers);
  std::memcpy(a.data(), interpolated.irradiance().data(), a.size() * sizeof(float));
  std::memcpy(b.data(), full.irradiance().data(), b.size() * sizeof(float));
  for (size_t i = 0; i < kReceivers; ++i) {
    EXPECT_NEAR(a[3 * i], b[3 * i], 0.1f * b[3 * i]) << "receiver " << i;
  }
}

TEST_F(PbgiServiceTest, RenderTileRequestErrors) {
  const std::string id = open_id();

  v1::RenderTileRequest r = tile_request(id);
  r.set_camera("/NoCamera");
  grpc::Status s = render(r);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_TRUE(mentions(s, "/NoCamera")) << s.error_message();
  EXPECT_TRUE(mentions(s, "a.usda")) << "names the scene: " << s.error_message();

  r = tile_request(id);
  r.mutable_tile()->set_x1(65);
  s = render(r);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::OUT_OF_RANGE);
  EXPECT_TRUE(mentions(s, "[32,65)x[32,48)")) << s.error_message();
  EXPECT_TRUE(mentions(s, "64x48")) << s.error_message();

  r = tile_request(id);
  r.mutable_tile()->set_y0(48);
  s = render(r);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << "empty tile";

  r = tile_request(id);
  r.set_image_width(0);
  EXPECT_EQ(render(r).error_code(), grpc::StatusCode::INVALID_ARGUMENT);

  r = tile_request(id);
  r.set_image_width(1000);
  r.set_image_height(1000);
  r.mutable_tile()->set_x1(200);
  r.mutable_tile()->set_y1(200);
  s = render(r);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_TRUE(mentions(s, "limit")) << s.error_message();

  r = tile_request("unknown-id");
  s = render(r);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_TRUE(mentions(s, "unknown-id")) << s.error_message();

  r = tile_request(id);
  r.mutable_options()->set_microbuffer_resolution(1000);
  s = render(r);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_TRUE(mentions(s, "microbuffer")) << s.error_message();
}

TEST_F(PbgiServiceTest, OpenSceneProgressHasElapsedAndEta) {
  std::vector<v1::OpenSceneEvent> events;
  ASSERT_TRUE(open("a.usda", &events).ok());
  ASSERT_GE(events.size(), 3u);
  for (size_t i = 0; i + 1 < events.size(); ++i) {
    const auto& p = events[i].progress();
    EXPECT_GE(p.elapsed_seconds(), 0.0);
    // Too early to estimate at 0%, nothing left at 100%.
    if (p.fraction() == 0.f) {
      EXPECT_LT(p.eta_seconds(), 0.0) << p.stage();
    }
    if (p.fraction() == 1.f) {
      EXPECT_EQ(p.eta_seconds(), 0.0) << p.stage();
    }
  }
}

TEST_F(PbgiServiceTest, OpenSceneStageSelectionIsCheckedAndPartOfTheKey) {
  grpc::ClientContext context;
  v1::OpenSceneRequest request;
  request.set_scene_path("a.usda");
  (*request.mutable_variant_selections())["/Car:color"] = "red";
  request.set_time_code(24.0);
  auto reader = stub->OpenScene(&context, request);
  v1::OpenSceneEvent event;
  while (reader->Read(&event)) {
  }
  ASSERT_TRUE(reader->Finish().ok());
  EXPECT_EQ(record().last_selection.variant_selections.at("/Car:color"), "red");
  ASSERT_TRUE(record().last_selection.time_code.has_value());
  EXPECT_EQ(*record().last_selection.time_code, 24.0);
  EXPECT_EQ(record().opens, 1);
  ASSERT_TRUE(open("a.usda").ok());
  EXPECT_EQ(record().opens, 2) << "no selection: another scene";
  EXPECT_TRUE(record().last_selection.empty());

  auto status_of = [&](const v1::OpenSceneRequest& r) {
    grpc::ClientContext c;
    auto rd = stub->OpenScene(&c, r);
    v1::OpenSceneEvent e;
    while (rd->Read(&e)) {
    }
    return rd->Finish();
  };
  for (const char* bad_key : {"Car:color", "/Car", "/Car:", ":color"}) {
    v1::OpenSceneRequest r;
    r.set_scene_path("a.usda");
    (*r.mutable_variant_selections())[bad_key] = "red";
    const grpc::Status s = status_of(r);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << bad_key;
    EXPECT_TRUE(mentions(s, "variant_selections")) << s.error_message();
  }
  v1::OpenSceneRequest r;
  r.set_scene_path("a.usda");
  r.set_time_code(std::numeric_limits<double>::quiet_NaN());
  const grpc::Status s = status_of(r);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_TRUE(mentions(s, "time_code")) << s.error_message();
  EXPECT_EQ(record().opens, 2);
}

TEST_F(PbgiServiceTest, GatherRejectsEmptyAndBadGlossyArrays) {
  const std::string id = open_id();
  const float up[3] = {0, 1, 0};
  v1::GatherRequest request;
  request.set_scene_id(id);
  grpc::Status s = gather(request);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << "no receivers";
  EXPECT_TRUE(mentions(s, "empty")) << s.error_message();

  request.set_positions(std::string(12, '\0'));
  request.set_normals(std::string(reinterpret_cast<const char*>(up), sizeof(up)));
  request.set_view_directions(std::string(24, '\0'));
  s = gather(request);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_TRUE(mentions(s, "view_directions")) << s.error_message();

  request.set_view_directions(std::string(reinterpret_cast<const char*>(up), sizeof(up)));
  const float rough = 1.5f;
  request.set_roughness(std::string(reinterpret_cast<const char*>(&rough), sizeof(rough)));
  s = gather(request);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_TRUE(mentions(s, "roughness[0]")) << s.error_message();

  const float nan_rgb[3] = {std::numeric_limits<float>::quiet_NaN(), 0, 0};
  request.clear_roughness();
  request.set_specular_color(std::string(reinterpret_cast<const char*>(nan_rgb), sizeof(nan_rgb)));
  s = gather(request);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_TRUE(mentions(s, "specular_color[0]")) << s.error_message();

  // A glossy request needs unit view directions and a roughness.
  const float white[3] = {1, 1, 1};
  request.set_specular_color(std::string(reinterpret_cast<const char*>(white), sizeof(white)));
  s = gather(request);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_TRUE(mentions(s, "roughness")) << s.error_message();
  const float longer[3] = {0, 2, 0};
  request.set_view_directions(std::string(reinterpret_cast<const char*>(longer), sizeof(longer)));
  s = gather(request);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_TRUE(mentions(s, "view_directions[0]")) << s.error_message();
}

TEST_F(PbgiServiceTest, GatherReturnsGlossyRadianceForGlossyReceivers) {
  std::vector<v1::OpenSceneEvent> events;
  ASSERT_TRUE(open("lit.usda", &events).ok());
  const std::string id = events.back().ready().scene_id();
  // Two receivers under the lit ceiling: a glossy one (roughness 0.3,
  // looking straight up) and a diffuse one (black specular colour).
  const float positions[6] = {0, 0, 0, 0.2f, 0, 0};
  const float normals[6] = {0, 0, 1, 0, 0, 1};
  const float views[6] = {0, 0, 1, 0, 0, 1};
  const float roughness[2] = {0.3f, 0.3f};
  const float specular[6] = {1, 1, 1, 0, 0, 0};
  auto bytes = [](const float* f, size_t n) {
    return std::string(reinterpret_cast<const char*>(f), n * sizeof(float));
  };
  v1::GatherRequest request;
  request.set_scene_id(id);
  request.set_positions(bytes(positions, 6));
  request.set_normals(bytes(normals, 6));
  {
    grpc::ClientContext context;
    v1::GatherResponse response;
    ASSERT_TRUE(stub->Gather(&context, request, &response).ok());
    EXPECT_TRUE(response.glossy().empty()) << "no glossy arrays, no glossy field";
    EXPECT_EQ(response.stats().glossy_receivers(), 0u);
  }
  request.set_view_directions(bytes(views, 6));
  request.set_roughness(bytes(roughness, 2));
  request.set_specular_color(bytes(specular, 6));
  grpc::ClientContext context;
  v1::GatherResponse response;
  const grpc::Status s = stub->Gather(&context, request, &response);
  ASSERT_TRUE(s.ok()) << s.error_message();
  ASSERT_EQ(response.glossy().size(), 6 * sizeof(float));
  float glossy[6], irradiance[6];
  std::memcpy(glossy, response.glossy().data(), sizeof(glossy));
  std::memcpy(irradiance, response.irradiance().data(), sizeof(irradiance));
  // The ceiling (radiance 1) fills most of a roughness-0.3 lobe aimed at
  // it: the glossy receiver reflects most of the lobe's albedo (< 1).
  EXPECT_GT(glossy[0], 0.5f);
  EXPECT_LT(glossy[0], 1.f);
  EXPECT_EQ(glossy[3], 0.f);
  EXPECT_GT(irradiance[0], 1.f);
  EXPECT_EQ(response.stats().glossy_receivers(), 1u);
  EXPECT_GT(response.stats().glossy_nodes_visited(), 0u);
}

// Bent normals come back only when asked for, one unit vector per receiver.
TEST_F(PbgiServiceTest, GatherReturnsBentNormalsWhenAsked) {
  std::vector<v1::OpenSceneEvent> events;
  ASSERT_TRUE(open("lit.usda", &events).ok());
  const float positions[6] = {0, 0, 0, 0.2f, 0, 0};
  const float normals[6] = {0, 0, 1, 0, 0, 1};
  v1::GatherRequest request;
  request.set_scene_id(events.back().ready().scene_id());
  request.set_positions(std::string(reinterpret_cast<const char*>(positions), sizeof(positions)));
  request.set_normals(std::string(reinterpret_cast<const char*>(normals), sizeof(normals)));
  {
    grpc::ClientContext context;
    v1::GatherResponse response;
    ASSERT_TRUE(stub->Gather(&context, request, &response).ok());
    EXPECT_TRUE(response.bent_normals().empty());
  }
  request.mutable_options()->set_bent_normal(true);
  grpc::ClientContext context;
  v1::GatherResponse response;
  const grpc::Status s = stub->Gather(&context, request, &response);
  ASSERT_TRUE(s.ok()) << s.error_message();
  ASSERT_EQ(response.bent_normals().size(), 6 * sizeof(float));
  float bent[6];
  std::memcpy(bent, response.bent_normals().data(), sizeof(bent));
  for (int i = 0; i < 2; ++i) {
    const Imath::V3f b(bent[3 * i], bent[3 * i + 1], bent[3 * i + 2]);
    EXPECT_NEAR(b.length(), 1.f, 1e-4f) << "receiver " << i;
    EXPECT_GT(b.z, 0.f) << "receiver " << i;  // in the receiver's hemisphere
  }
}

// GetStatus reports the daemon's memory budget and who holds it: the
// accountant's charges by kind, the reserve, the floor and the refusals.
TEST(PbgiServiceStatus, ReportsTheMemoryBudgetAndItsChargesByKind) {
  constexpr uint64_t kMiB = uint64_t(1) << 20;
  auto cache = std::make_shared<storage::PageCache>(0);
  auto memory = MemoryAccountant::create({100 * kMiB, 10 * kMiB, 20 * kMiB}, cache);
  auto registry = std::make_shared<SceneRegistry>(
      [](const fs::path& path, const OpenOptions&, const StageSelection&, const StageProgress&,
         const std::function<bool()>&) { return testing::fake_session(path.string(), "id"); });
  ServiceRuntime runtime;
  runtime.cache = cache;
  runtime.memory = memory;
  const PbgiService service(ServiceOptions{}, SceneRoots({}), registry, runtime);

  MemoryCharge open = memory->charge("/s/open.usda", "geometry", 30 * kMiB);
  MemoryCharge read = memory->charge("/s/read.usda", "scene being read", 5 * kMiB, ChargeKind::kRead);
  open.resize(ChargeKind::kBuild, 7 * kMiB, "page-set build");
  EXPECT_THROW(memory->charge("/s/huge.usda", "geometry", 71 * kMiB), ResourceExhausted);

  const v1::GetStatusResponse status = service.status();
  ASSERT_TRUE(status.has_memory());
  const v1::MemoryStatus& m = status.memory();
  EXPECT_EQ(m.budget_bytes(), 100 * kMiB);
  EXPECT_EQ(m.request_reserve_bytes(), 10 * kMiB);
  EXPECT_EQ(m.page_cache_floor_bytes(), 20 * kMiB);
  EXPECT_EQ(m.scenes_bytes(), 30 * kMiB);
  EXPECT_EQ(m.reading_bytes(), 5 * kMiB);
  EXPECT_EQ(m.builds_bytes(), 7 * kMiB);
  EXPECT_EQ(m.refusals(), 1u);
  EXPECT_EQ(status.cache().budget_bytes(), (100 - 10 - 30 - 5 - 7) * kMiB) << "the page cache gets the rest";

  // The metrics say the same.
  const std::string text = prometheus_text(status, {});
  for (const std::string& line : {"pbgi_memory_budget_bytes " + std::to_string(100 * kMiB) + "\n",
                                  "pbgi_memory_charged_bytes{kind=\"scenes\"} " + std::to_string(30 * kMiB) + "\n",
                                  "pbgi_memory_charged_bytes{kind=\"reading\"} " + std::to_string(5 * kMiB) + "\n",
                                  "pbgi_memory_charged_bytes{kind=\"builds\"} " + std::to_string(7 * kMiB) + "\n",
                                  std::string("pbgi_memory_refusals_total 1\n")}) {
    EXPECT_NE(text.find(line), std::string::npos) << "missing: " << line << text;
  }

  // A read that becomes an open scene moves its bytes, the total unchanged.
  read.reclassify(ChargeKind::kRead, ChargeKind::kScene);
  EXPECT_EQ(service.status().memory().reading_bytes(), 0u);
  EXPECT_EQ(service.status().memory().scenes_bytes(), 35 * kMiB);
  EXPECT_EQ(service.status().cache().budget_bytes(), 48 * kMiB);
}

// GetStatus and the metrics report the pages the cache evicted while a
// gather pins them (memory beside the cache's budget), now and at most.
TEST(PbgiServiceStatus, ReportsPagesPinnedBeyondTheCache) {
  auto page = [](uint32_t id) {
    auto p = std::make_shared<tree::Page>();
    p->id = id;
    p->nodes.resize(10);
    return p;
  };
  const uint64_t bytes = page(0)->memory_bytes() + storage::PageCache::entry_bytes();
  auto cache = std::make_shared<storage::PageCache>(bytes + bytes / 2);  // room for one page
  ServiceRuntime runtime;
  runtime.cache = cache;
  auto registry = std::make_shared<SceneRegistry>(
      [](const fs::path& path, const OpenOptions&, const StageSelection&, const StageProgress&,
         const std::function<bool()>&) { return testing::fake_session(path.string(), "id"); });
  const PbgiService service(ServiceOptions{}, SceneRoots({}), registry, runtime);

  tree::PagePtr pinned = cache->get(1, 0, [&] { return page(0); });
  cache->get(1, 1, [&] { return page(1); });  // evicts page 0, still pinned
  v1::GetStatusResponse status = service.status();
  EXPECT_EQ(status.cache().bytes_pinned(), bytes);
  EXPECT_EQ(status.cache().bytes_pinned_peak(), bytes);
  const std::string text = prometheus_text(status, {});
  EXPECT_NE(text.find("pbgi_cache_pinned_bytes " + std::to_string(bytes) + "\n"), std::string::npos) << text;
  pinned.reset();
  status = service.status();
  EXPECT_EQ(status.cache().bytes_pinned(), 0u);
  EXPECT_EQ(status.cache().bytes_pinned_peak(), bytes);
}

TEST_F(PbgiServiceTest, UnloadSceneAndStatus) {
  const std::string id = open_id();
  {
    grpc::ClientContext context;
    v1::GetStatusResponse status;
    ASSERT_TRUE(stub->GetStatus(&context, v1::GetStatusRequest(), &status).ok());
    ASSERT_EQ(status.scenes_size(), 1);
    EXPECT_EQ(status.scenes(0).info().scene_id(), id);
    EXPECT_EQ(status.scenes(0).memory_bytes(), 12u * 200) << "12 triangles, estimated";
    EXPECT_GT(status.rss_bytes(), 0u);
    EXPECT_GT(status.requests().max_in_flight(), 0u);
    EXPECT_EQ(status.requests().in_flight(), 0u);
  }
  auto unload = [&](const std::string& scene_id) {
    grpc::ClientContext context;
    v1::UnloadSceneRequest request;
    request.set_scene_id(scene_id);
    v1::UnloadSceneResponse response;
    return stub->UnloadScene(&context, request, &response);
  };
  EXPECT_TRUE(unload(id).ok());
  grpc::Status s = unload(id);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_TRUE(mentions(s, id)) << s.error_message();
  EXPECT_EQ(unload("").error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(render(tile_request(id)).error_code(), grpc::StatusCode::NOT_FOUND)
      << "an unloaded scene is gone";

  // Opening it again builds a new session.
  const int before = record().opens;
  EXPECT_FALSE(open_id().empty());
  EXPECT_EQ(record().opens, before + 1);
}

TEST_F(PbgiServiceTest, RenderTilesChecksEveryTileBeforeRendering) {
  const std::string id = open_id();
  auto render_tiles = [&](const v1::RenderTilesRequest& request, int* received) {
    grpc::ClientContext context;
    auto reader = stub->RenderTiles(&context, request);
    v1::RenderTileResponse response;
    *received = 0;
    while (reader->Read(&response)) ++*received;
    return reader->Finish();
  };
  v1::RenderTilesRequest request;
  request.set_scene_id(id);
  request.set_camera("/Camera");
  request.set_image_width(64);
  request.set_image_height(48);
  int received = -1;
  grpc::Status s = render_tiles(request, &received);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_TRUE(mentions(s, "tiles is empty")) << s.error_message();

  // The bad tile is the second: nothing is rendered (the fake session has
  // no tree: rendering the first would crash the test).
  for (uint32_t x0 : {0u, 32u}) {
    v1::Tile* t = request.add_tiles();
    t->set_x0(x0);
    t->set_y0(0);
    t->set_x1(x0 + 32);
    t->set_y1(16);
  }
  request.mutable_tiles(1)->set_x1(65);
  s = render_tiles(request, &received);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::OUT_OF_RANGE);
  EXPECT_TRUE(mentions(s, "tiles[1]")) << s.error_message();
  EXPECT_EQ(received, 0);

  request.mutable_tiles(1)->set_x1(32);
  s = render_tiles(request, &received);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << "empty tile";
  EXPECT_TRUE(mentions(s, "tiles[1]")) << s.error_message();

  request.set_camera("/Nope");
  EXPECT_EQ(render_tiles(request, &received).error_code(), grpc::StatusCode::NOT_FOUND);
}

}  // namespace
}  // namespace pbgi::service
