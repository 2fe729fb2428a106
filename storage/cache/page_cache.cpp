#include "storage/cache/page_cache.h"

#include "common/errors.h"
#include "storage/cache/frequency_sketch.h"

#include <algorithm>
#include <condition_variable>
#include <exception>
#include <list>
#include <mutex>
#include <optional>
#include <unordered_map>
#include <vector>

namespace pbgi::storage {

namespace {

struct Key {
  uint64_t owner;
  uint32_t page;
  bool operator==(const Key&) const = default;
};

struct KeyHash {
  size_t operator()(const Key& k) const {
    uint64_t h = k.owner * 0x9E3779B97F4A7C15ull ^ (uint64_t(k.page) + 0x632BE59BD9B4E019ull);
    h ^= h >> 29;
    return static_cast<size_t>(h * 0xBF58476D1CE4E5B9ull);
  }
};

// Where a held page is (W-TinyLFU's three LRU lists, page_cache.h).
enum class Segment : uint8_t { kWindow, kProbation, kProtected };

struct Entry {
  tree::PagePtr page;
  uint64_t bytes = 0;
  Segment segment = Segment::kWindow;
  std::list<Key>::iterator pos;
};

// The frequency sketch's share of a held page. The sketch has fewer than 8
// bytes an item (8 counters of 4 bits, rounded up to a power of two) and
// is sized for twice the pages held when it is resized (fit_sketch()):
// under 16 bytes a page then, less as the holdings grow.
constexpr uint64_t kSketchBytesPerPage = 16;

// What holding a page costs the cache itself, charged with the page: the
// node of `held` (its link, key, entry and cached hash), its bucket, the
// page's node in its list (two links and the key), as heap blocks, and its
// share of the frequency sketch. About 150 bytes: a half of a cut-shaped
// page's bytes on disk.
constexpr uint64_t kEntryBytes =
    tree::heap_block_bytes(sizeof(void*) + sizeof(std::pair<const Key, Entry>) + sizeof(size_t)) + sizeof(void*) +
    tree::heap_block_bytes(2 * sizeof(void*) + sizeof(Key)) + kSketchBytesPerPage;

// The window's share of the budget (TinyLFU's 1%): a page used twice in
// quick succession is not judged by its frequency.
constexpr uint64_t kWindowShare = 100;
// The protected list's share of the main part (Caffeine's 80%).
constexpr uint64_t kProtectedPercent = 80;

// Departed pages remembered (pages evicted while in use): each keeps the
// control block of its shared_ptr (sizeof(tree::Page)) alive, so their
// number is bounded by the pages held.
constexpr size_t kMinDeparted = 256;

struct Departed {
  Key key;
  std::weak_ptr<const tree::Page> page;
};

// A load in flight, which the callers that miss the same page wait for.
// Not a std::promise: its set_value() goes through pthread_once, which
// makes a futex system call whether or not anyone waits, on every miss
// (two thirds of the gather's futex calls at 1/8 of the 2M city).
struct Pending {
  tree::PagePtr page;
  std::exception_ptr error;
  bool done = false;  // guarded by PageCache::Impl::mu
  int waiters = 0;    // guarded by PageCache::Impl::mu
};

}  // namespace

struct PageCache::Impl {
  uint64_t budget;  // guarded by mu (set_budget)
  mutable std::mutex mu;
  // Front = most recently used, in each list.
  std::list<Key> window;     // pages that just came
  std::list<Key> probation;  // admitted, used once since
  std::list<Key> protect;    // admitted and used again
  uint64_t window_bytes = 0, protect_bytes = 0;
  FrequencySketch sketch;
  // Pages evicted while someone still held them (a gather's pins), front =
  // newest: a miss of such a page takes it back if it is still alive,
  // instead of loading and decoding a second copy of it.
  std::list<Departed> departed;
  std::unordered_map<Key, std::list<Departed>::iterator, KeyHash> departed_index;
  std::unordered_map<Key, Entry, KeyHash> held;
  std::unordered_map<Key, std::shared_ptr<Pending>, KeyHash> loading;
  // Notified when a load that callers wait for ends.
  std::condition_variable loaded;
  CacheCounters counters;
  // Outside mu: loaders add to it while other threads fetch.
  std::atomic<uint64_t> bytes_read{0};
  std::atomic<uint64_t> next_owner{1};
  // Pages dropped under the lock, released by the caller after unlocking:
  // the last reference to a page frees its view, which must not lengthen
  // the critical section that every fetch of every gather goes through.
  std::vector<tree::PagePtr> released;

  explicit Impl(uint64_t b) : budget(b) {}

  // Requires mu. The pages dropped since the last call, to be destroyed
  // once the lock is released.
  std::vector<tree::PagePtr> take_released() {
    std::vector<tree::PagePtr> out;
    out.swap(released);
    return out;
  }

  static uint64_t hash(const Key& key) { return KeyHash{}(key); }
  std::list<Key>& list_of(Segment s) {
    return s == Segment::kWindow ? window : s == Segment::kProbation ? probation : protect;
  }

  // Requires mu. The sketch sized for twice the pages held, resized (its
  // counts forgotten) only when the holdings outgrow it or fall below a
  // quarter of it: under 16 bytes a page held after a resize, under 8 once
  // the holdings have doubled, up to 32 while they shrink to a quarter;
  // and not reset by the ups and downs of a full cache.
  void fit_sketch() {
    const size_t n = held.size();
    if (n > sketch.items() || (n >= 8 && 4 * n < sketch.items())) sketch.resize(2 * n);
  }

  // Requires mu.
  void remember_departed(const Key& key, const tree::PagePtr& page) {
    if (auto d = departed_index.find(key); d != departed_index.end()) {
      departed.erase(d->second);
      departed_index.erase(d);
    }
    departed.push_front({key, page});
    departed_index[key] = departed.begin();
    const size_t cap = std::max(kMinDeparted, held.size());
    while (departed.size() > cap) {
      departed_index.erase(departed.back().key);
      departed.pop_back();
    }
  }

  // Requires mu. The page `key` if it departed and is still alive
  // (forgotten either way), else null.
  tree::PagePtr take_departed(const Key& key) {
    auto d = departed_index.find(key);
    if (d == departed_index.end()) return nullptr;
    tree::PagePtr page = d->second->page.lock();
    departed.erase(d->second);
    departed_index.erase(d);
    return page;
  }

  // Requires mu. Drops the held page `key`; `evicted`: counted, and
  // remembered if still in use.
  void drop(const Key& key, bool evicted) {
    auto it = held.find(key);
    Entry& e = it->second;
    list_of(e.segment).erase(e.pos);
    if (e.segment == Segment::kWindow) window_bytes -= e.bytes;
    if (e.segment == Segment::kProtected) protect_bytes -= e.bytes;
    counters.bytes_held -= e.bytes;
    if (evicted) {
      // Still used (the cache's reference is not the only one): remembered.
      if (e.page.use_count() > 1) remember_departed(key, e.page);
      ++counters.evictions;
    }
    released.push_back(std::move(e.page));
    held.erase(it);
  }

  // Requires mu. Moves a held page to the front of `to`.
  void move(Entry& e, Segment to) {
    std::list<Key>& dst = list_of(to);
    dst.splice(dst.begin(), list_of(e.segment), e.pos);
    if (e.segment == Segment::kWindow) window_bytes -= e.bytes;
    if (e.segment == Segment::kProtected) protect_bytes -= e.bytes;
    if (to == Segment::kWindow) window_bytes += e.bytes;
    if (to == Segment::kProtected) protect_bytes += e.bytes;
    e.segment = to;
  }

  uint64_t window_budget() const { return budget / kWindowShare; }
  uint64_t protect_budget() const { return (budget - window_budget()) / 100 * kProtectedPercent; }

  // Requires mu. A hit: a page used again in probation is protected; the
  // protected pages beyond their share go back to probation, least
  // recently used first.
  void on_hit(Entry& e) {
    if (e.segment == Segment::kProbation) {
      move(e, Segment::kProtected);
      while (protect_bytes > protect_budget() && protect.size() > 1) {
        move(held.find(protect.back())->second, Segment::kProbation);
      }
    } else {
      std::list<Key>& l = list_of(e.segment);
      l.splice(l.begin(), l, e.pos);
    }
  }

  // Requires mu. Drops one page, for a smaller budget: the least recently
  // used of probation, else of the protected pages, else of the window.
  void evict_one() {
    const std::list<Key>& from = !probation.empty() ? probation : !protect.empty() ? protect : window;
    drop(from.back(), true);
  }

  // Requires mu. The pages the window holds beyond its share leave it,
  // oldest first, as candidates for the main part: a candidate is admitted
  // while the budget has room, or by evicting the main part's least
  // recently used page if the candidate is used more often than it; else
  // the candidate is evicted. The window keeps at least its newest page.
  void admit_from_window() {
    while (window_bytes > window_budget() && window.size() > 1) {
      const Key candidate = window.back();
      move(held.find(candidate)->second, Segment::kProbation);
      while (counters.bytes_held > budget) {
        const bool other_on_probation = probation.back() != candidate;
        if (!other_on_probation && protect.empty()) break;
        const Key victim = other_on_probation ? probation.back() : protect.back();
        if (sketch.estimate(hash(candidate)) > sketch.estimate(hash(victim))) {
          drop(victim, true);
        } else {
          drop(candidate, true);
          break;
        }
      }
    }
    while (counters.bytes_held > budget) evict_one();
  }

  // Requires mu. Holds `page` (in the window) if it fits the budget.
  void hold(const Key& key, const tree::PagePtr& page) {
    const uint64_t bytes = page->memory_bytes() + kEntryBytes;
    if (bytes > budget || held.count(key)) return;
    window.push_front(key);
    held.emplace(key, Entry{page, bytes, Segment::kWindow, window.begin()});
    window_bytes += bytes;
    counters.bytes_held += bytes;
    fit_sketch();
    admit_from_window();
  }
};

uint64_t PageCache::entry_bytes() { return kEntryBytes; }

PageCache::PageCache(uint64_t budget_bytes) : impl_(std::make_unique<Impl>(budget_bytes)) {}
PageCache::~PageCache() = default;

tree::PagePtr PageCache::get(uint64_t owner, uint32_t page_id,
                             const std::function<tree::PagePtr()>& load) {
  const Key key{owner, page_id};
  // Made only on a miss: a hit (every page of every gather, once the cache
  // is warm) allocates nothing.
  std::shared_ptr<Pending> pending;
  {
    std::unique_lock lock(impl_->mu);
    impl_->sketch.add(Impl::hash(key));
    if (auto it = impl_->held.find(key); it != impl_->held.end()) {
      ++impl_->counters.hits;
      impl_->on_hit(it->second);
      return it->second.page;
    }
    if (auto it = impl_->loading.find(key); it != impl_->loading.end()) {
      ++impl_->counters.hits;
      const std::shared_ptr<Pending> other = it->second;
      ++other->waiters;
      impl_->loaded.wait(lock, [&] { return other->done; });
      --other->waiters;
      if (other->error) std::rethrow_exception(other->error);
      return other->page;
    }
    // Evicted while in use and still alive: taken back, no load (a hit),
    // and held again as a page that just came.
    if (tree::PagePtr back = impl_->take_departed(key)) {
      ++impl_->counters.hits;
      impl_->hold(key, back);
      const std::vector<tree::PagePtr> dropped = impl_->take_released();
      lock.unlock();
      return back;
    }
    ++impl_->counters.misses;
    pending = std::make_shared<Pending>();
    impl_->loading.emplace(key, pending);
  }

  // Load outside the lock: I/O and decoding must not block other pages.
  tree::PagePtr page;
  std::exception_ptr error;
  try {
    page = load();
    if (!page) throw Error("page loader returned no page for page " + std::to_string(page_id));
  } catch (...) {
    error = std::current_exception();
  }
  std::vector<tree::PagePtr> dropped;  // released after the lock
  bool wake = false;
  {
    std::lock_guard lock(impl_->mu);
    impl_->loading.erase(key);
    if (!error) {
      impl_->hold(key, page);  // nothing is cached for a failed load
      dropped = impl_->take_released();
    }
    pending->page = page;
    pending->error = error;
    pending->done = true;
    wake = pending->waiters > 0;
  }
  if (wake) impl_->loaded.notify_all();
  if (error) std::rethrow_exception(error);
  return page;
}

void PageCache::note_bytes_read(uint64_t n) { impl_->bytes_read.fetch_add(n, std::memory_order_relaxed); }

CacheCounters PageCache::counters() const {
  std::lock_guard lock(impl_->mu);
  CacheCounters c = impl_->counters;
  c.bytes_read = impl_->bytes_read.load(std::memory_order_relaxed);
  return c;
}

uint64_t PageCache::budget() const {
  std::lock_guard lock(impl_->mu);
  return impl_->budget;
}

void PageCache::set_budget(uint64_t budget_bytes) {
  std::vector<tree::PagePtr> dropped;  // released after the lock
  std::lock_guard lock(impl_->mu);
  impl_->budget = budget_bytes;
  while (impl_->counters.bytes_held > impl_->budget) impl_->evict_one();
  impl_->fit_sketch();
  dropped = impl_->take_released();
}

uint64_t PageCache::new_owner() { return impl_->next_owner.fetch_add(1); }

void PageCache::forget(uint64_t owner) {
  std::vector<tree::PagePtr> dropped;  // released after the lock
  std::lock_guard lock(impl_->mu);
  std::vector<Key> keys;
  for (const auto& [key, entry] : impl_->held) {
    if (key.owner == owner) keys.push_back(key);
  }
  for (const Key& key : keys) impl_->drop(key, false);
  for (auto it = impl_->departed.begin(); it != impl_->departed.end();) {
    if (it->key.owner == owner) {
      impl_->departed_index.erase(it->key);
      it = impl_->departed.erase(it);
    } else {
      ++it;
    }
  }
  impl_->fit_sketch();
  dropped = impl_->take_released();
}

}  // namespace pbgi::storage
