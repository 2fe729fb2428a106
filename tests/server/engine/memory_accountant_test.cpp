// The daemon's memory accountant: charges and their release size the page
// cache; a charge that does not fit unloads idle scenes (the reclaimer),
// then takes the cache to its floor, and is refused naming the scene and
// the bytes it needs when even that is not enough.
#include "server/engine/memory_accountant.h"

#include "common/errors.h"
#include "storage/cache/page_cache.h"

#include <gtest/gtest.h>

#include <atomic>
#include <memory>
#include <string>
#include <thread>
#include <vector>

namespace pbgi {
namespace {

constexpr uint64_t kMiB = uint64_t(1) << 20;

MemoryBudget budget_of(uint64_t total_mib, uint64_t reserve_mib = 10, uint64_t floor_mib = 20) {
  return {total_mib * kMiB, reserve_mib * kMiB, floor_mib * kMiB};
}

// A page of about `nodes` nodes (the cache's unit of holding).
tree::PagePtr make_page(uint32_t id, size_t nodes) {
  auto p = std::make_shared<tree::Page>();
  p->id = id;
  p->nodes.resize(nodes);
  return p;
}

TEST(MemoryAccountant, TheCacheGetsWhatTheReserveAndChargesLeave) {
  auto cache = std::make_shared<storage::PageCache>(0);
  auto memory = MemoryAccountant::create(budget_of(100), cache);
  EXPECT_EQ(cache->budget(), 90 * kMiB);  // 100 - 10 reserved for requests
  {
    MemoryCharge a = memory->charge("/s/a.usda", "geometry", 30 * kMiB);
    EXPECT_EQ(memory->charged(), 30 * kMiB);
    EXPECT_EQ(cache->budget(), 60 * kMiB);
    a.resize(20 * kMiB, "measured");  // the measured size is smaller
    EXPECT_EQ(cache->budget(), 70 * kMiB);
    MemoryCharge moved = std::move(a);
    EXPECT_EQ(memory->charged(), 20 * kMiB);
  }
  EXPECT_EQ(memory->charged(), 0u);  // released with the charge
  EXPECT_EQ(cache->budget(), 90 * kMiB);
}

// With a cap (page_cache_limit) the cache holds at most the cap while the
// budget leaves it more, and less when charges leave it less.
TEST(MemoryAccountant, ACappedCacheTakesTheLesserOfItsCapAndWhatIsLeft) {
  auto cache = std::make_shared<storage::PageCache>(0);
  MemoryBudget budget = budget_of(100);
  budget.cache_limit = 25 * kMiB;
  auto memory = MemoryAccountant::create(budget, cache);
  EXPECT_EQ(cache->budget(), 25 * kMiB);
  EXPECT_EQ(memory->usage().cache_budget, 25 * kMiB);
  {
    MemoryCharge a = memory->charge("/s/a.usda", "geometry", 60 * kMiB);
    EXPECT_EQ(cache->budget(), 25 * kMiB);  // 30 left, capped at 25
    a.resize(70 * kMiB, "measured");
    EXPECT_EQ(cache->budget(), 20 * kMiB);  // 20 left
  }
  EXPECT_EQ(cache->budget(), 25 * kMiB);
}

TEST(MemoryAccountant, AChargeShrinksTheCacheEvictingPages) {
  const uint64_t page = make_page(0, 1000)->memory_bytes() + storage::PageCache::entry_bytes();  // as held
  auto cache = std::make_shared<storage::PageCache>(0);
  auto memory = MemoryAccountant::create({100 * page, 0, 10 * page}, cache);
  for (uint32_t id = 0; id < 80; ++id) cache->get(1, id, [&] { return make_page(id, 1000); });
  ASSERT_EQ(cache->counters().bytes_held, 80 * page);
  MemoryCharge scene = memory->charge("/s/big.usda", "geometry", 50 * page);
  EXPECT_EQ(cache->budget(), 50 * page);
  EXPECT_LE(cache->counters().bytes_held, 50 * page);
  EXPECT_GE(cache->counters().evictions, 30u);
}

TEST(MemoryAccountant, RefusesWhatCanNeverFitNamingSceneAndBytes) {
  auto memory = MemoryAccountant::create(budget_of(100), nullptr);
  int reclaims = 0;
  memory->set_reclaimer([&](uint64_t) { return ++reclaims, false; });
  try {
    memory->charge("/scenes/huge.usda", "scene geometry", 71 * kMiB);  // 70 MiB is all scenes get
    FAIL() << "charged more than the budget gives";
  } catch (const ResourceExhausted& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("/scenes/huge.usda"), std::string::npos) << what;
    EXPECT_NE(what.find(std::to_string(71 * kMiB) + " bytes"), std::string::npos) << what;
    EXPECT_NE(what.find("100.0 MiB"), std::string::npos) << what;  // the budget
    EXPECT_NE(what.find("70.0 MiB"), std::string::npos) << what;   // what scenes may get
    EXPECT_NE(what.find("memory_budget"), std::string::npos) << what;
  }
  EXPECT_EQ(reclaims, 0) << "nothing is unloaded for a scene that could never fit";
  EXPECT_EQ(memory->charged(), 0u);
  EXPECT_EQ(memory->refusals(), 1u);
  EXPECT_NO_THROW(memory->charge("/scenes/fits.usda", "scene geometry", 70 * kMiB));
}

TEST(MemoryAccountant, UnloadsIdleScenesBeforeRefusing) {
  auto memory = MemoryAccountant::create(budget_of(100), nullptr);
  // Two idle scenes the reclaimer may unload, oldest first.
  std::vector<MemoryCharge> idle;
  idle.push_back(memory->charge("/s/old.usda", "geometry", 30 * kMiB));
  idle.push_back(memory->charge("/s/newer.usda", "geometry", 30 * kMiB));
  std::vector<uint64_t> asked;
  memory->set_reclaimer([&](uint64_t bytes) {
    asked.push_back(bytes);
    if (idle.empty()) return false;
    idle.erase(idle.begin());
    return true;
  });
  MemoryCharge next = memory->charge("/s/next.usda", "geometry", 35 * kMiB);
  ASSERT_EQ(asked.size(), 1u) << "one unload made room";
  EXPECT_EQ(asked[0], 25 * kMiB) << "asked for what the charge lacked: 60 + 35 - 70";
  EXPECT_EQ(idle.size(), 1u);
  EXPECT_EQ(memory->charged(), 65 * kMiB);
  // Growing a charge goes the same way: the last idle scene goes, then the
  // growth is refused (nothing more to unload) and the charge is unchanged.
  EXPECT_THROW(next.resize(71 * kMiB, "page-set build (estimated)"), ResourceExhausted);
  EXPECT_EQ(next.bytes(), 35 * kMiB);
  next.resize(70 * kMiB, "page-set build (estimated)");
  EXPECT_TRUE(idle.empty());
  EXPECT_EQ(memory->charged(), 70 * kMiB);
}

TEST(MemoryAccountant, RefusalNamesWhatOtherScenesInUseHold) {
  auto memory = MemoryAccountant::create(budget_of(100), nullptr);
  MemoryCharge busy = memory->charge("/s/busy.usda", "geometry", 50 * kMiB);
  memory->set_reclaimer([](uint64_t) { return false; });  // nothing idle
  try {
    memory->charge("/s/b.usda", "scene geometry + ray-tracing structure (estimated)", 30 * kMiB);
    FAIL();
  } catch (const ResourceExhausted& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("/s/b.usda"), std::string::npos) << what;
    EXPECT_NE(what.find("ray-tracing structure"), std::string::npos) << what;
    EXPECT_NE(what.find("other scenes in use hold 50.0 MiB"), std::string::npos) << what;
  }
  EXPECT_EQ(memory->charged(), 50 * kMiB);
}

TEST(MemoryAccountant, ChargesOutliveTheDaemonsReference) {
  MemoryCharge charge;
  {
    auto memory = MemoryAccountant::create(budget_of(100), nullptr);
    charge = memory->charge("/s/a.usda", "geometry", kMiB);
  }
  charge.release();  // the accountant is still alive through the charge
  EXPECT_EQ(charge.bytes(), 0u);
}

TEST(MemoryAccountant, BudgetWithoutRoomForScenesIsInvalid) {
  EXPECT_THROW(MemoryAccountant::create(budget_of(30, 10, 20), nullptr), InvalidArgument);
  EXPECT_THROW(MemoryAccountant::create(budget_of(5, 10, 0), nullptr), InvalidArgument);
}

TEST(MemoryAccountant, ConcurrentChargesNeverPassTheBudget) {
  auto cache = std::make_shared<storage::PageCache>(0);
  auto memory = MemoryAccountant::create(budget_of(100), cache);
  std::atomic<int> refused{0};
  std::vector<std::thread> threads;
  threads.reserve(4);
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([&] {
      for (int i = 0; i < 2000; ++i) {
        try {
          MemoryCharge c = memory->charge("/s/x.usda", "geometry", 30 * kMiB);
          EXPECT_LE(memory->charged(), 70 * kMiB);
          EXPECT_GE(cache->budget(), 20 * kMiB);
        } catch (const ResourceExhausted&) {
          ++refused;
        }
      }
    });
  }
  for (auto& t : threads) t.join();
  EXPECT_EQ(memory->charged(), 0u);
  EXPECT_EQ(cache->budget(), 90 * kMiB);
}

TEST(MemoryAccountant, AChargeKeepsItsPartsByKindAndTheTotalsFollow) {
  auto cache = std::make_shared<storage::PageCache>(0);
  auto memory = MemoryAccountant::create(budget_of(100), cache);
  {
    // A scene read chunk by chunk, then open, then built.
    MemoryCharge c = memory->charge("/s/a.usda", "scene being read", 0, ChargeKind::kRead);
    for (uint64_t mib = 5; mib <= 20; mib += 5) c.resize(ChargeKind::kRead, mib * kMiB, "chunk");
    EXPECT_EQ(memory->usage().charged[size_t(ChargeKind::kRead)], 20 * kMiB);
    EXPECT_EQ(cache->budget(), 70 * kMiB);
    c.reclassify(ChargeKind::kRead, ChargeKind::kScene);
    EXPECT_EQ(c.bytes(ChargeKind::kRead), 0u);
    EXPECT_EQ(c.bytes(ChargeKind::kScene), 20 * kMiB);
    EXPECT_EQ(memory->charged(), 20 * kMiB) << "reclassifying moves bytes, it charges none";
    c.resize(ChargeKind::kBuild, 15 * kMiB, "page-set build");
    const MemoryUsage u = memory->usage();
    EXPECT_EQ(u.charged[size_t(ChargeKind::kScene)], 20 * kMiB);
    EXPECT_EQ(u.charged[size_t(ChargeKind::kRead)], 0u);
    EXPECT_EQ(u.charged[size_t(ChargeKind::kBuild)], 15 * kMiB);
    EXPECT_EQ(u.charged_total(), 35 * kMiB);
    EXPECT_EQ(u.cache_budget, 55 * kMiB);
    EXPECT_EQ(c.bytes(), 35 * kMiB);
    // A growth of one part is refused against the whole charge: 36 MiB more
    // would make 71 of the 70 scenes may hold.
    try {
      c.resize(ChargeKind::kBuild, 51 * kMiB, "page-set build");
      FAIL() << "charged past the budget";
    } catch (const ResourceExhausted& e) {
      EXPECT_NE(std::string(e.what()).find("35.0 MiB held"), std::string::npos) << e.what();
    }
    EXPECT_EQ(c.bytes(ChargeKind::kBuild), 15 * kMiB) << "a refused growth leaves the charge as it was";
    EXPECT_EQ(memory->usage().refusals, 1u);
    c.resize(ChargeKind::kBuild, 0, "page-set build");
    EXPECT_EQ(memory->usage().charged[size_t(ChargeKind::kBuild)], 0u);
  }
  const MemoryUsage after = memory->usage();
  EXPECT_EQ(after.charged_total(), 0u) << "every part released with the charge";
  EXPECT_EQ(after.cache_budget, 90 * kMiB);
}

}  // namespace
}  // namespace pbgi
