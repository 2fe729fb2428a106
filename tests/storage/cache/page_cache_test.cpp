// The page cache: byte budget, W-TinyLFU admission (scan resistance), counters,
// single load under concurrency, and identical traversals whatever the
// budget.
#include "storage/cache/page_cache.h"
#include "common/errors.h"
#include "storage/pages/page_set.h"
#include "storage/tree/memory_tree.h"
#include "tests/storage/pages/temp_dir.h"
#include "tests/storage/pages/tree_walk.h"
#include "tests/storage/tree/random_surfels.h"

#include <gtest/gtest.h>

#include <atomic>
#include <future>
#include <thread>
#include <vector>

namespace pbgi::storage {
namespace {

// A page whose memory_bytes() is about `nodes` nodes.
tree::PagePtr make_page(uint32_t id, size_t nodes) {
  auto p = std::make_shared<tree::Page>();
  p->id = id;
  p->nodes.resize(nodes);
  return p;
}

// What the cache charges for holding such a page: its bytes and the cache's own.
const uint64_t kPageBytes = make_page(0, 10)->memory_bytes() + PageCache::entry_bytes();

// Fetches pages of owner 1 (pages of 10 nodes), counting the loads.
struct CountingFetch {
  PageCache& cache;
  int loads = 0;
  tree::PagePtr operator()(uint32_t id) {
    return cache.get(1, id, [&] {
      ++loads;
      return make_page(id, 10);
    });
  }
};

// Waits until `callers` fetches are counted (one miss, the others hits
// waiting on its load): every caller has asked before the load goes on.
void wait_for_callers(const PageCache& cache, uint64_t callers) {
  while (true) {
    const CacheCounters c = cache.counters();
    if (c.hits + c.misses == callers) return;
    std::this_thread::yield();
  }
}

TEST(PageCache, HoldsWithinBudgetAndAdmitsPagesUsedMoreOften) {
  PageCache cache(3 * kPageBytes + kPageBytes / 2);  // room for 3 pages
  CountingFetch get{cache};
  int& loads = get.loads;
  for (uint32_t id = 0; id < 3; ++id) get(id);
  EXPECT_EQ(cache.counters().bytes_held, 3 * kPageBytes);
  EXPECT_EQ(cache.counters().evictions, 0u);
  // 3 comes: 2 leaves the window as a candidate, used no more often than
  // 0, the least recently used admitted page: 2 is evicted, not 0.
  get(3);
  EXPECT_EQ(cache.counters().evictions, 1u);
  get(2);  // used twice now; 3 (once) is the candidate and loses to 0
  EXPECT_EQ(loads, 5);
  get(3);  // 2 (twice) leaves the window and evicts 0 (once)
  EXPECT_EQ(loads, 6);
  EXPECT_EQ(cache.counters().evictions, 3u);
  get(1);
  get(2);
  get(3);
  EXPECT_EQ(loads, 6);  // 1, 2 and 3 held
  get(0);
  EXPECT_EQ(loads, 7);
  const CacheCounters c = cache.counters();
  EXPECT_EQ(c.misses, 7u);
  EXPECT_EQ(c.hits, 3u);
  EXPECT_LE(c.bytes_held, cache.budget());
  EXPECT_EQ(c.bytes_held, 3 * kPageBytes);
}

// Batches of receivers that each fetch more pages than the budget holds,
// in the same order, as a render's tiles do: the cache keeps a fixed part
// of them and hits it every round. A recency order (LRU, or 2Q's LRU of
// pages seen twice) evicts each page just before it is needed again and
// hits nothing.
TEST(PageCache, RepeatedSweepsLargerThanTheBudgetKeepHitting) {
  PageCache cache(20 * kPageBytes);
  for (int round = 0; round < 10; ++round) {
    for (uint32_t id = 0; id < 30; ++id) cache.get(1, id, [&] { return make_page(id, 10); });
  }
  const CacheCounters before = cache.counters();
  for (int round = 0; round < 10; ++round) {
    for (uint32_t id = 0; id < 30; ++id) cache.get(1, id, [&] { return make_page(id, 10); });
  }
  const CacheCounters c = cache.counters();
  EXPECT_GE(c.hits - before.hits, 10u * 15u);  // at least half of the 300 fetches
  EXPECT_LE(c.bytes_held, cache.budget());
}

// A page evicted while a gather still holds it (pinned) is taken back by
// the next miss of it: no second load, the same page, counted as a hit
// and held again. A page evicted while unused is loaded again.
TEST(PageCache, PageEvictedWhileInUseIsTakenBackNotLoaded) {
  PageCache cache(kPageBytes + kPageBytes / 2);  // room for 1 page
  CountingFetch get{cache};
  int& loads = get.loads;
  const tree::PagePtr pinned = get(0);
  get(1);  // evicts 0, which `pinned` still holds
  EXPECT_EQ(cache.counters().evictions, 1u);
  const tree::PagePtr again = get(0);  // evicts 1, unused: not remembered
  EXPECT_EQ(again.get(), pinned.get());
  EXPECT_EQ(loads, 2);
  EXPECT_EQ(cache.counters().hits, 1u);
  EXPECT_EQ(cache.counters().bytes_held, kPageBytes);
  get(0);  // held again
  EXPECT_EQ(cache.counters().hits, 2u);
  get(1);  // evicted while unused: loaded again
  EXPECT_EQ(loads, 3);
  EXPECT_LE(cache.counters().bytes_held, cache.budget());
}

// What gathers pin beyond the budget is reported: a page evicted while
// in use counts in bytes_pinned until its last user lets go (the peak
// stays). Before, nothing said that a cache of 1/8 of a 2M-surfel page set
// had the gathers' pins as much again beside it.
TEST(PageCache, PagesEvictedWhileInUseAreReportedAsPinned) {
  PageCache cache(kPageBytes + kPageBytes / 2);  // room for 1 page
  auto get = [&](uint32_t id) { return cache.get(1, id, [&] { return make_page(id, 10); }); };
  tree::PagePtr pinned = get(0);
  get(1);  // evicts 0 while in use
  get(2);  // evicts 1, unused
  CacheCounters c = cache.counters();
  EXPECT_EQ(c.bytes_held, kPageBytes);
  EXPECT_EQ(c.bytes_pinned, kPageBytes);
  EXPECT_EQ(c.bytes_pinned_peak, kPageBytes);
  pinned.reset();  // the gather lets go
  c = cache.counters();
  EXPECT_EQ(c.bytes_pinned, 0u);
  EXPECT_EQ(c.bytes_pinned_peak, kPageBytes);
  EXPECT_EQ(c.bytes_held, kPageBytes);
}

// A departed page that died meanwhile is loaded again; forget() drops the
// owner's departed pages too.
TEST(PageCache, DepartedPageThatDiedIsLoadedAgain) {
  PageCache cache(kPageBytes + kPageBytes / 2);
  int loads = 0;
  auto get = [&](uint64_t owner, uint32_t id) {
    return cache.get(owner, id, [&] {
      ++loads;
      return make_page(id, 10);
    });
  };
  tree::PagePtr pinned = get(1, 0);
  get(1, 1);       // evicts 0 while in use
  pinned.reset();  // then it dies
  get(1, 0);
  EXPECT_EQ(loads, 3);
  pinned = get(2, 5);
  get(2, 6);  // evicts (2, 5) while in use
  cache.forget(2);
  get(2, 5);  // forgotten: loaded, not taken back
  EXPECT_EQ(loads, 6);
}

// Many departed pages whose users let go in any order, some taken back
// meanwhile: the cache keeps them in an array it removes from by moving
// its last entry, and each page must stay found under its own key. Every
// page still in use is taken back (the same page, no load), every other
// one loaded again, and bytes_pinned is exactly the pages still in use
// that the cache does not hold.
TEST(PageCache, DepartedPagesStayFoundWhileUsersComeAndGo) {
  PageCache cache(kPageBytes + kPageBytes / 2);  // room for 1 page
  CountingFetch get{cache};
  int& loads = get.loads;
  constexpr uint32_t kPages = 200;
  std::vector<tree::PagePtr> users(kPages);
  for (uint32_t id = 0; id < kPages; ++id) users[id] = get(id);
  uint32_t rng = 12345;
  for (int round = 0; round < 4; ++round) {
    // Users let go of a pseudo-random third of the pages...
    for (uint32_t id = 0; id < kPages; ++id) {
      rng = rng * 1664525u + 1013904223u;
      if ((rng >> 16) % 3 == 0) users[id].reset();
    }
    // ... and misses sweep some of the departed (page ids beyond kPages).
    for (uint32_t k = 0; k < 20; ++k) get(kPages + 20 * round + k);
    uint64_t in_use = 0;
    for (const tree::PagePtr& p : users) in_use += p ? 1 : 0;
    const CacheCounters c = cache.counters();
    EXPECT_EQ(c.bytes_pinned, in_use * kPageBytes) << "round " << round;
    // Every page again: the ones in use are taken back, the rest loaded.
    for (uint32_t id = 0; id < kPages; ++id) {
      const int before = loads;
      const tree::PagePtr p = get(id);
      ASSERT_EQ(p->id, id);
      if (users[id]) {
        EXPECT_EQ(p.get(), users[id].get()) << "page " << id;
        EXPECT_EQ(loads, before) << "page " << id;
      } else {
        EXPECT_EQ(loads, before + 1) << "page " << id;
        users[id] = p;  // in use again
      }
    }
  }
}
TEST(PageCache, SmallerBudgetEvictsDownToItLargerHoldsMore) {
  PageCache cache(4 * kPageBytes);
  auto get = [&](uint32_t id) { return cache.get(1, id, [&] { return make_page(id, 10); }); };
  for (uint32_t id = 0; id < 4; ++id) get(id);
  ASSERT_EQ(cache.counters().bytes_held, 4 * kPageBytes);
  cache.set_budget(2 * kPageBytes);  // a scene came: the cache gives way
  EXPECT_EQ(cache.budget(), 2 * kPageBytes);
  EXPECT_EQ(cache.counters().bytes_held, 2 * kPageBytes);
  EXPECT_EQ(cache.counters().evictions, 2u);
  cache.set_budget(0);
  EXPECT_EQ(cache.counters().bytes_held, 0u);
  cache.set_budget(3 * kPageBytes);  // it left: the cache grows again
  for (uint32_t id = 0; id < 3; ++id) get(id);
  EXPECT_EQ(cache.counters().bytes_held, 3 * kPageBytes);
}

TEST(PageCache, HotPagesSurviveScans) {
  // A page every gather needs (the top of the tree) between long runs of
  // pages needed once: scans do not evict it. A plain LRU would lose it to
  // every scan.
  PageCache cache(4 * kPageBytes);
  int hot_loads = 0;
  uint32_t next_cold = 100;
  auto touch_hot = [&] {
    cache.get(1, 0, [&] {
      ++hot_loads;
      return make_page(0, 10);
    });
  };
  auto scan = [&] {
    for (int i = 0; i < 20; ++i) {
      const uint32_t id = next_cold++;
      cache.get(1, id, [&] { return make_page(id, 10); });
      ASSERT_LE(cache.counters().bytes_held, cache.budget());
    }
  };
  touch_hot();
  touch_hot();  // used twice: more often than any page of a scan
  for (int round = 0; round < 5; ++round) {
    scan();
    touch_hot();
  }
  EXPECT_EQ(hot_loads, 1);
}

TEST(PageCache, OwnersAreSeparateAndForgettable) {
  PageCache cache(uint64_t(1) << 30);
  const uint64_t a = cache.new_owner(), b = cache.new_owner();
  ASSERT_NE(a, b);
  cache.get(a, 0, [] { return make_page(0, 10); });
  const auto pb = cache.get(b, 0, [] { return make_page(0, 20); });
  EXPECT_EQ(pb->nodes.size(), 20u);  // not a's page 0
  EXPECT_EQ(cache.counters().misses, 2u);
  cache.forget(a);
  EXPECT_EQ(cache.counters().bytes_held, pb->memory_bytes() + PageCache::entry_bytes());
  int loads = 0;
  cache.get(a, 0, [&] {
    ++loads;
    return make_page(0, 10);
  });
  EXPECT_EQ(loads, 1);
}

TEST(PageCache, ZeroBudgetHoldsNothing) {
  PageCache cache(0);
  int loads = 0;
  for (int i = 0; i < 3; ++i) {
    const auto p = cache.get(1, 7, [&] {
      ++loads;
      return make_page(7, 10);
    });
    EXPECT_EQ(p->id, 7u);
  }
  EXPECT_EQ(loads, 3);
  EXPECT_EQ(cache.counters().bytes_held, 0u);
  EXPECT_EQ(cache.counters().evictions, 0u);
}

TEST(PageCache, PageLargerThanBudgetIsServedNotHeld) {
  PageCache cache(kPageBytes);
  cache.get(1, 0, [] { return make_page(0, 10); });
  EXPECT_EQ(cache.counters().bytes_held, kPageBytes);
  const auto big = cache.get(1, 1, [] { return make_page(1, 1000); });
  EXPECT_EQ(big->nodes.size(), 1000u);
  EXPECT_EQ(cache.counters().bytes_held, kPageBytes);  // page 0 kept, big not held
}

TEST(PageCache, FailedLoadIsNotCached) {
  PageCache cache(uint64_t(1) << 20);
  EXPECT_THROW(cache.get(1, 0, []() -> tree::PagePtr { throw CorruptionError("bad page 0"); }), CorruptionError);
  int loads = 0;
  cache.get(1, 0, [&] {
    ++loads;
    return make_page(0, 1);
  });
  EXPECT_EQ(loads, 1);
}

TEST(PageCache, ConcurrentMissesLoadOnce) {
  PageCache cache(uint64_t(1) << 20);
  std::atomic<int> loads{0};
  std::promise<void> release;
  std::shared_future<void> released = release.get_future().share();
  constexpr int kThreads = 8;
  std::vector<std::thread> threads;
  std::vector<tree::PagePtr> got(kThreads);
  for (int i = 0; i < kThreads; ++i) {
    threads.emplace_back([&, i] {
      got[i] = cache.get(1, 42, [&] {
        ++loads;
        released.wait();  // hold the load open until every thread asked
        return make_page(42, 10);
      });
    });
  }
  wait_for_callers(cache, kThreads);
  release.set_value();
  for (auto& t : threads) t.join();
  EXPECT_EQ(loads.load(), 1);
  for (const auto& p : got) EXPECT_EQ(p.get(), got[0].get());
}

// The callers waiting on a load that fails get its exception, and the page
// is loaded again by the next caller.
TEST(PageCache, ConcurrentMissesShareAFailedLoad) {
  PageCache cache(uint64_t(1) << 20);
  std::atomic<int> loads{0};
  std::promise<void> release;
  std::shared_future<void> released = release.get_future().share();
  constexpr int kThreads = 6;
  std::atomic<int> failed{0};
  std::vector<std::thread> threads;
  threads.reserve(kThreads);
  for (int i = 0; i < kThreads; ++i) {
    threads.emplace_back([&] {
      try {
        cache.get(1, 7, [&]() -> tree::PagePtr {
          ++loads;
          released.wait();
          throw CorruptionError("page 7 is damaged");
        });
      } catch (const CorruptionError& e) {
        if (std::string(e.what()).find("page 7") != std::string::npos) ++failed;
      }
    });
  }
  wait_for_callers(cache, kThreads);
  release.set_value();
  for (auto& t : threads) t.join();
  EXPECT_EQ(loads.load(), 1);
  EXPECT_EQ(failed.load(), kThreads);
  EXPECT_EQ(cache.counters().bytes_held, 0u);
  const auto page = cache.get(1, 7, [&] {
    ++loads;
    return make_page(7, 3);
  });
  EXPECT_EQ(loads.load(), 2);
  EXPECT_EQ(page->nodes.size(), 3u);
}

// Forgetting some owners' pages (deletions from the cache's index) keeps
// every other page findable: fetching them again loads nothing. Page ids
// are scattered so that keys collide in the index.
TEST(PageCache, ForgettingOwnersKeepsTheOthersPagesFound) {
  PageCache cache(uint64_t(1) << 30);
  std::vector<uint64_t> owners(8);
  for (uint64_t& o : owners) o = cache.new_owner();
  std::vector<uint32_t> ids;
  uint64_t state = 99;
  for (int i = 0; i < 300; ++i) {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    ids.push_back(uint32_t(state >> 32));
  }
  int loads = 0;
  auto fetch_all = [&](uint64_t owner) {
    for (uint32_t id : ids) {
      const tree::PagePtr p = cache.get(owner, id, [&] {
        ++loads;
        return make_page(id, 1);
      });
      ASSERT_EQ(p->id, id);
    }
  };
  for (uint64_t o : owners) fetch_all(o);
  ASSERT_EQ(loads, 2400);
  for (int o = 0; o < 8; o += 2) cache.forget(owners[o]);
  for (int o = 1; o < 8; o += 2) fetch_all(owners[o]);
  EXPECT_EQ(loads, 2400);
  for (int o = 0; o < 8; o += 2) fetch_all(owners[o]);
  EXPECT_EQ(loads, 3600);
}

// Random fetches of three owners' pages through a budget of a few dozen
// pages, with owners forgotten now and then: every fetch returns the page
// it names (the index finds the right slot after its deletions shift
// entries), and the holdings stay within the budget.
TEST(PageCache, RandomFetchesReturnThePagesTheyName) {
  PageCache cache(40 * kPageBytes);
  uint64_t owners[3] = {cache.new_owner(), cache.new_owner(), cache.new_owner()};
  uint64_t state = 12345;
  auto next = [&] {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return uint32_t(state >> 33);
  };
  std::vector<tree::PagePtr> pinned;  // some pages stay in use, so some evictions are remembered
  for (int i = 0; i < 20000; ++i) {
    const int o = int(next() % 3);
    const uint32_t id = next() % 300;
    const tree::PagePtr p = cache.get(owners[o], id, [&] { return make_page(id + 1000u * uint32_t(o), 10); });
    ASSERT_EQ(p->id, id + 1000u * uint32_t(o)) << "fetch " << i;
    if (next() % 8 == 0) pinned.push_back(p);
    if (pinned.size() > 30) pinned.erase(pinned.begin());
    ASSERT_LE(cache.counters().bytes_held, cache.budget());
    if (i % 5000 == 4999) {
      cache.forget(owners[o]);
      owners[o] = cache.new_owner();
    }
  }
  const CacheCounters c = cache.counters();
  EXPECT_GT(c.hits, 0u);
  EXPECT_GT(c.evictions, 0u);
}

class CacheOverPageSet : public ::testing::Test {
 protected:
  void SetUp() override {
    surfels_ = test::random_surfels(2000, 21);
    options_.page_size = 4096;
    build_page_set(surfels_, options_, "k", tmp_.path() / "set");
    want_ = test::walk(tree::MemoryTree(tree::build_tree(surfels_, options_)));
    // The largest decoded page (what the budget counts; pages decode to
    // several times their size on disk).
    PageSetReader probe(tmp_.path() / "set", nullptr);
    for (uint32_t p = 0; p < probe.manifest().stats.page_count; ++p)
      one_page_ = std::max<uint64_t>(one_page_, probe.page(p)->memory_bytes() + PageCache::entry_bytes());
  }
  uint64_t one_page_ = 0;
  test::TempDir tmp_;
  std::vector<Surfel> surfels_;
  tree::BuildOptions options_;
  test::Walk want_;
};

TEST_F(CacheOverPageSet, TraversalsIdenticalWhateverTheBudget) {
  const uint64_t one_page = one_page_;  // a budget of exactly one page
  for (uint64_t budget : {uint64_t(0), one_page, ~uint64_t(0)}) {
    auto cache = std::make_shared<PageCache>(budget);
    PageSetReader reader(tmp_.path() / "set", cache);
    const uint32_t pages = reader.manifest().stats.page_count;
    ASSERT_GT(pages, 10u);
    auto check = [&] { ASSERT_LE(cache->counters().bytes_held, budget); };
    test::expect_same_walk(test::walk(reader, check), want_);
    test::expect_same_walk(test::walk(reader, check), want_);
    const CacheCounters c = cache->counters();
    EXPECT_GT(c.bytes_read, 0u);
    if (budget == 0) {
      EXPECT_EQ(c.hits, 0u);
      EXPECT_EQ(c.bytes_held, 0u);
    } else if (budget == one_page) {
      EXPECT_GT(c.evictions, 0u);
      EXPECT_LE(c.bytes_held, one_page);
    } else {
      // Unlimited: each page read once, the second walk all hits.
      EXPECT_EQ(c.misses, pages);
      EXPECT_EQ(c.evictions, 0u);
      uint64_t page_bytes = 0;
      for (const auto& e : reader.manifest().pages) page_bytes += e.bytes;
      EXPECT_EQ(c.bytes_read, page_bytes);
    }
  }
}

TEST_F(CacheOverPageSet, BudgetHoldsUnderConcurrentReaders) {
  const uint64_t budget = 3 * one_page_;
  auto cache = std::make_shared<PageCache>(budget);
  PageSetReader reader(tmp_.path() / "set", cache);
  std::atomic<bool> over{false};
  std::vector<std::thread> threads;
  std::vector<test::Walk> got(4);
  for (int i = 0; i < 4; ++i) {
    threads.emplace_back([&, i] {
      got[i] = test::walk(reader, [&] {
        if (cache->counters().bytes_held > budget) over = true;
      });
    });
  }
  for (auto& t : threads) t.join();
  EXPECT_FALSE(over.load());
  for (const auto& w : got) test::expect_same_walk(w, want_);
  EXPECT_GT(cache->counters().evictions, 0u);
}

TEST_F(CacheOverPageSet, ClosedReaderReleasesItsPages) {
  auto cache = std::make_shared<PageCache>(uint64_t(1) << 30);
  {
    PageSetReader reader(tmp_.path() / "set", cache);
    test::walk(reader);
    EXPECT_GT(cache->counters().bytes_held, 0u);
  }
  EXPECT_EQ(cache->counters().bytes_held, 0u);
}

}  // namespace
}  // namespace pbgi::storage
