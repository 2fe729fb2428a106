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
  SceneRegistry registry([&](const std::filesystem::path& path, const OpenOptions&, const StageSelection&,
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
  SceneRegistry registry([&](const std::filesystem::path& path, const OpenOptions&, const StageSelection&,
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
  SceneRegistry registry([&](const std::filesystem::path& path, const OpenOptions&, const StageSelection&,
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
  SceneRegistry registry([&](const std::filesystem::path& path, const OpenOptions&, const StageSelection&,
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
  SceneRegistry registry([&](const std::filesystem::path& path, const OpenOptions&, const StageSelection&,
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

TEST(SceneRegistry, EvictsLeastRecentlyUsedScenesOverTheMemoryBudget) {
  int opens = 0;
  RegistryOptions options;
  options.scene_memory_budget = 2500;
  options.memory_of = [](const SceneSession&) -> uint64_t { return 1000; };
  SceneRegistry registry(
      [&](const std::filesystem::path& path, const OpenOptions&, const StageSelection&,
          const StageProgress&) {
        ++opens;
        return testing::fake_session(path, "id-" + path.stem().string());
      },
      options);
  registry.open("/s/a.usda", {});
  registry.open("/s/b.usda", {});
  ASSERT_NE(registry.find("id-a"), nullptr);   // a is now more recent than b
  registry.open("/s/c.usda", {});              // 3000 > 2500: b goes
  EXPECT_EQ(registry.evictions(), 1u);
  EXPECT_NE(registry.find("id-a"), nullptr);
  EXPECT_EQ(registry.find("id-b"), nullptr);
  EXPECT_NE(registry.find("id-c"), nullptr);
  ASSERT_EQ(registry.usage().size(), 2u);
  EXPECT_EQ(registry.usage()[0].memory_bytes, 1000u);

  // Opening b again opens it anew (and evicts the least recent: a).
  registry.open("/s/b.usda", {});
  EXPECT_EQ(opens, 4);
  EXPECT_EQ(registry.find("id-a"), nullptr);
  EXPECT_EQ(registry.evictions(), 2u);

  // A scene larger than the whole budget still opens (alone).
  options.scene_memory_budget = 500;
  SceneRegistry small([&](const std::filesystem::path& path, const OpenOptions&,
                          const StageSelection&, const StageProgress&) {
    return testing::fake_session(path, "id-" + path.stem().string());
  }, options);
  EXPECT_NE(small.open("/s/a.usda", {}), nullptr);
  EXPECT_NE(small.open("/s/b.usda", {}), nullptr);
  EXPECT_EQ(small.list().size(), 1u);
}

TEST(SceneRegistry, UnloadForgetsTheSessionAndItsKey) {
  int opens = 0;
  SceneRegistry registry([&](const std::filesystem::path& path, const OpenOptions&,
                             const StageSelection&, const StageProgress&) {
    ++opens;
    return testing::fake_session(path, "id-" + std::to_string(opens));
  });
  const auto first = registry.open("/s/a.usda", {});
  EXPECT_FALSE(registry.unload("nope"));
  EXPECT_TRUE(registry.unload("id-1"));
  EXPECT_EQ(registry.find("id-1"), nullptr);
  EXPECT_TRUE(registry.list().empty());
  EXPECT_EQ(first->info.scene_id, "id-1") << "a holder keeps a valid session";
  const auto second = registry.open("/s/a.usda", {});
  EXPECT_EQ(opens, 2);
  EXPECT_EQ(second->info.scene_id, "id-2");

  StageSelection selection;
  selection.time_code = 3.0;
  registry.open("/s/a.usda", {}, selection);
  EXPECT_EQ(opens, 3) << "another stage selection, another session";
  registry.open("/s/a.usda", {}, selection);
  EXPECT_EQ(opens, 3);
}

}  // namespace
}  // namespace pbgi::service
