// The registry opens each (path, options) once, even under concurrent
// requests, does not cache failures, and lets a waiting caller give up.
#include "server/service/scene_registry.h"

#include "storage/format/errors.h"
#include "tests/server/service/fake_sessions.h"

#include <gtest/gtest.h>

#include <atomic>
#include <future>
#include <latch>
#include <thread>

namespace pbgi::service {
namespace {

TEST(SceneRegistry, SameKeyOpensOnceUnderConcurrency) {
  std::atomic<int> opens{0};
  std::promise<void> release;
  std::shared_future<void> released = release.get_future().share();
  SceneRegistry registry([&](const std::filesystem::path& path, const OpenOptions&,
                             const StageProgress& progress) {
    ++opens;
    progress("ingest", 0.5f);
    released.wait();  // hold the open until every caller has been started
    return testing::fake_session(path, "id-" + std::to_string(opens.load()));
  });

  constexpr int kCallers = 8;
  std::latch started(kCallers);
  std::vector<std::shared_ptr<SceneSession>> got(kCallers);
  std::vector<std::thread> callers;
  for (int i = 0; i < kCallers; ++i) {
    callers.emplace_back([&, i] {
      started.count_down();
      got[i] = registry.open("/scenes/a.usda", OpenOptions());
    });
  }
  started.wait();
  release.set_value();
  for (auto& t : callers) t.join();

  EXPECT_EQ(opens, 1);
  EXPECT_EQ(registry.opens_started(), 1u);
  for (const auto& session : got) EXPECT_EQ(session, got[0]);
  EXPECT_EQ(registry.find("id-1"), got[0]);
  EXPECT_EQ(registry.list().size(), 1u);
}

TEST(SceneRegistry, DifferentOptionsOrPathsAreDifferentSessions) {
  int opens = 0;
  SceneRegistry registry([&](const std::filesystem::path& path, const OpenOptions&,
                             const StageProgress&) {
    return testing::fake_session(path, "id-" + std::to_string(++opens));
  });
  OpenOptions small;
  small.surfels.target_surfels = 100;
  auto a = registry.open("/scenes/b.usda", OpenOptions());
  auto b = registry.open("/scenes/b.usda", small);
  auto c = registry.open("/scenes/a.usda", OpenOptions());
  auto a_again = registry.open("/scenes/b.usda", OpenOptions());
  EXPECT_EQ(opens, 3);
  EXPECT_EQ(a, a_again);
  EXPECT_NE(a, b);
  const auto listed = registry.list();
  ASSERT_EQ(listed.size(), 3u);
  EXPECT_EQ(listed[0]->info.scene_path, "/scenes/a.usda");  // ordered by path
  EXPECT_EQ(registry.find("nope"), nullptr);
}

TEST(SceneRegistry, FailuresAreRethrownAndNotCached) {
  int opens = 0;
  SceneRegistry registry([&](const std::filesystem::path& path, const OpenOptions&,
                             const StageProgress&) -> std::shared_ptr<SceneSession> {
    if (++opens == 1) throw SceneError("'/scenes/a.usda': prim </World/Bad>: broken");
    return testing::fake_session(path, "id");
  });
  EXPECT_THROW(registry.open("/scenes/a.usda", OpenOptions()), SceneError);
  EXPECT_TRUE(registry.list().empty());
  EXPECT_NE(registry.open("/scenes/a.usda", OpenOptions()), nullptr);
  EXPECT_EQ(opens, 2);
}

TEST(SceneRegistry, CallerRunningTheOpenSeesItsProgress) {
  SceneRegistry registry([&](const std::filesystem::path& path, const OpenOptions&,
                             const StageProgress& progress) {
    progress("ingest", 0.f);
    progress("surfels", 1.f);
    return testing::fake_session(path, "id");
  });
  std::vector<std::string> stages;
  registry.open("/a.usda", OpenOptions(), [&](const std::string& s, float) { stages.push_back(s); });
  EXPECT_EQ(stages, (std::vector<std::string>{"ingest", "surfels"}));
}

TEST(SceneRegistry, WaiterCanBeCancelled) {
  std::promise<void> in_open, release;
  std::shared_future<void> released = release.get_future().share();
  SceneRegistry registry([&](const std::filesystem::path& path, const OpenOptions&,
                             const StageProgress&) {
    in_open.set_value();
    released.wait();
    return testing::fake_session(path, "id");
  });
  std::thread first([&] { registry.open("/a.usda", OpenOptions()); });
  in_open.get_future().wait();  // the open is in flight: the next caller waits
  EXPECT_THROW(registry.open("/a.usda", OpenOptions(), {}, [] { return true; }), Cancelled);
  release.set_value();
  first.join();
  EXPECT_NE(registry.find("id"), nullptr) << "the open itself went on";
}

}  // namespace
}  // namespace pbgi::service
