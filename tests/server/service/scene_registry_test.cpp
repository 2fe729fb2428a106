// The registry opens each (path, options) once, even under concurrent
// requests, does not cache failures, lets a waiting caller give up, and
// cancels an open once every caller waiting for it has left.
#include "server/service/scene_registry.h"

#include "common/errors.h"
#include "tests/server/service/fake_sessions.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
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
                             const StageProgress& progress, const std::function<bool()>&) {
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
                             const StageProgress&, const std::function<bool()>&) {
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
                             const StageProgress&, const std::function<bool()>&) -> std::shared_ptr<SceneSession> {
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
                             const StageProgress& progress, const std::function<bool()>&) {
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
                             const StageProgress&, const std::function<bool()>&) {
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

// An opener that runs until it is cancelled (Cancelled) or `finish` is set.
SceneOpener open_until_cancelled(std::latch& in_open, std::atomic<bool>& finish,
                                 std::atomic<bool>& saw_cancel) {
  return [&](const std::filesystem::path& path, const OpenOptions&, const StageSelection&,
             const StageProgress&, const std::function<bool()>& cancelled) {
    in_open.count_down();
    while (!finish) {
      if (cancelled()) {
        saw_cancel = true;
        throw Cancelled("open of " + path.string() + " cancelled");
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    return testing::fake_session(path, "id");
  };
}

// Regression (issue 17): an open went on after its only client had gone.
TEST(SceneRegistry, OpenIsCancelledWhenItsOnlyCallerLeaves) {
  std::latch in_open(1);
  std::atomic<bool> finish{false}, saw_cancel{false}, gone{false};
  SceneRegistry registry(open_until_cancelled(in_open, finish, saw_cancel));
  std::exception_ptr error;
  std::thread caller([&] {
    try {
      registry.open("/a.usda", OpenOptions(), {}, [&] { return gone.load(); });
    } catch (...) {
      error = std::current_exception();
    }
  });
  in_open.wait();
  gone = true;
  caller.join();
  EXPECT_TRUE(saw_cancel) << "the opener was told to stop";
  ASSERT_TRUE(error);
  EXPECT_THROW(std::rethrow_exception(error), Cancelled);
  EXPECT_TRUE(registry.opening().empty());
  EXPECT_TRUE(registry.list().empty()) << "a cancelled open is not cached";
}

TEST(SceneRegistry, SharedOpenGoesOnWhileAnyCallerStaysAndStopsWhenAllLeave) {
  for (const bool second_leaves : {false, true}) {
    SCOPED_TRACE(second_leaves ? "both callers leave" : "the second caller stays");
    std::latch in_open(1);
    std::atomic<bool> finish{false}, saw_cancel{false}, first_gone{false}, second_gone{false};
    std::atomic<int> first_polls{0}, second_polls{0};
    SceneRegistry registry(open_until_cancelled(in_open, finish, saw_cancel));
    std::exception_ptr first_error, second_error;
    std::shared_ptr<SceneSession> second_session;
    std::thread first([&] {
      try {
        registry.open("/a.usda", OpenOptions(), {}, [&] {
          ++first_polls;
          return first_gone.load();
        });
      } catch (...) {
        first_error = std::current_exception();
      }
    });
    in_open.wait();
    std::thread second([&] {
      try {
        second_session = registry.open("/a.usda", OpenOptions(), {}, [&] {
          ++second_polls;
          return second_gone.load();
        });
      } catch (...) {
        second_error = std::current_exception();
      }
    });
    while (second_polls == 0) std::this_thread::yield();  // polled once seated
    first_gone = true;
    // Two more polls of the first caller: the opener asked at least once
    // with the first caller gone and the second still there.
    for (const int polls = first_polls; first_polls < polls + 2;) std::this_thread::yield();
    EXPECT_FALSE(saw_cancel) << "cancelled although a caller still waits";
    if (second_leaves) {
      second_gone = true;
    } else {
      finish = true;
    }
    first.join();
    second.join();
    EXPECT_EQ(saw_cancel.load(), second_leaves);
    if (second_leaves) {
      ASSERT_TRUE(second_error);
      EXPECT_THROW(std::rethrow_exception(second_error), Cancelled);
      EXPECT_TRUE(registry.list().empty());
    } else {
      EXPECT_FALSE(second_error);
      ASSERT_NE(second_session, nullptr);
      EXPECT_EQ(second_session->info.scene_id, "id");
    }
  }
}

// A caller still there when the open it joined was cancelled (by callers
// that left before it was seated) is not failed: it opens again.
TEST(SceneRegistry, CallerStillThereRestartsAnOpenItsOtherCallersCancelled) {
  std::latch in_open(1);
  std::atomic<int> opens{0};
  std::atomic<bool> waiter_seated{false};
  SceneRegistry registry([&](const std::filesystem::path& path, const OpenOptions&, const StageSelection&,
                             const StageProgress&, const std::function<bool()>&) -> std::shared_ptr<SceneSession> {
    if (++opens == 1) {
      in_open.count_down();
      while (!waiter_seated) std::this_thread::yield();
      throw Cancelled("every caller seen so far left");
    }
    return testing::fake_session(path, "id");
  });
  std::thread first([&] {
    EXPECT_THROW(registry.open("/a.usda", OpenOptions(), {}, [] { return true; }), Cancelled);
  });
  in_open.wait();
  const auto session = registry.open("/a.usda", OpenOptions(), {}, [&] {
    waiter_seated = true;
    return false;
  });
  first.join();
  ASSERT_NE(session, nullptr);
  EXPECT_EQ(opens, 2);
}

TEST(SceneRegistry, EvictsLeastRecentlyUsedScenesOverTheMemoryBudget) {
  int opens = 0;
  RegistryOptions options;
  options.scene_memory_budget = 2500;
  options.memory_of = [](const SceneSession&) -> uint64_t { return 1000; };
  SceneRegistry registry(
      [&](const std::filesystem::path& path, const OpenOptions&, const StageSelection&,
          const StageProgress&, const std::function<bool()>&) {
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
                          const StageSelection&, const StageProgress&, const std::function<bool()>&) {
    return testing::fake_session(path, "id-" + path.stem().string());
  }, options);
  EXPECT_NE(small.open("/s/a.usda", {}), nullptr);
  EXPECT_NE(small.open("/s/b.usda", {}), nullptr);
  EXPECT_EQ(small.list().size(), 1u);
}

// With the daemon's memory accountant: a scene that does not fit unloads
// idle scenes (least recently used first), never one a request holds, and
// is refused naming itself when only scenes in use are left.
TEST(SceneRegistry, MakesRoomByUnloadingIdleScenesOnlyForTheMemoryBudget) {
  constexpr uint64_t kMiB = uint64_t(1) << 20;
  auto memory = MemoryAccountant::create({100 * kMiB, 10 * kMiB, 20 * kMiB}, nullptr);  // 70 MiB for scenes
  auto registry =
      std::make_shared<SceneRegistry>([&](const std::filesystem::path& path, const OpenOptions&, const StageSelection&,
                                          const StageProgress&, const std::function<bool()>&) {
        auto session = testing::fake_session(path, "id-" + path.stem().string());
        session->memory = memory->charge(path.string(), "scene geometry", 40 * kMiB);
        return session;
      });
  memory->set_reclaimer([&](uint64_t bytes) { return registry->unload_idle(bytes); });

  registry->open("/s/a.usda", {});
  EXPECT_EQ(registry->usage().at(0).memory_bytes, 40 * kMiB) << "the charge is the session's memory";
  registry->open("/s/b.usda", {});  // 80 > 70: a, idle, goes
  EXPECT_EQ(registry->find("id-a"), nullptr);
  EXPECT_EQ(registry->evictions(), 1u);
  EXPECT_EQ(memory->charged(), 40 * kMiB);

  const auto in_use = registry->find("id-b");  // a request holds b
  try {
    registry->open("/s/c.usda", {});
    FAIL() << "c fitted beside b in use";
  } catch (const ResourceExhausted& e) {
    EXPECT_NE(std::string(e.what()).find("/s/c.usda"), std::string::npos) << e.what();
  }
  EXPECT_NE(registry->find("id-b"), nullptr) << "a scene in use is never unloaded for room";
  EXPECT_EQ(memory->charged(), 40 * kMiB);

  EXPECT_FALSE(registry->unload_idle(1)) << "nothing idle";
}

TEST(SceneRegistry, UnloadForgetsTheSessionAndItsKey) {
  int opens = 0;
  SceneRegistry registry([&](const std::filesystem::path& path, const OpenOptions&,
                             const StageSelection&, const StageProgress&, const std::function<bool()>&) {
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
