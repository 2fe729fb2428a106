#include "storage/cache/page_cache.h"

#include "common/errors.h"

#include <algorithm>
#include <future>
#include <list>
#include <mutex>
#include <optional>
#include <unordered_map>

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

struct Entry {
  tree::PagePtr page;
  uint64_t bytes = 0;
  bool hot = false;                 // in `hot` (LRU), else in `fresh` (FIFO)
  std::list<Key>::iterator pos;
};

// What holding a page costs the cache itself, charged with the page: the
// node of `held` (its link, key, entry and cached hash), its bucket and
// the page's node in `fresh` or `hot` (two links and the key), as heap
// blocks. About 136 bytes: a fifth of a cut-shaped page's bytes on disk.
constexpr uint64_t kEntryBytes = tree::heap_block_bytes(sizeof(void*) + sizeof(std::pair<const Key, Entry>) +
                                                        sizeof(size_t)) +
                                 sizeof(void*) + tree::heap_block_bytes(2 * sizeof(void*) + sizeof(Key));

// Ghosts remembered: enough to recognise a page coming back after every
// page of a long scan went through, at a few dozen bytes each.
constexpr size_t kMinGhosts = 1024;
constexpr size_t kGhostsPerHeldPage = 8;
// Departed pages remembered (pages evicted while in use): each keeps the
// control block of its shared_ptr (sizeof(tree::Page)) alive, so their
// number is bounded by the pages held.
constexpr size_t kMinDeparted = 256;

struct Departed {
  Key key;
  std::weak_ptr<const tree::Page> page;
};

}  // namespace

struct PageCache::Impl {
  uint64_t budget;  // guarded by mu (set_budget)
  mutable std::mutex mu;
  std::list<Key> fresh;  // first-time pages, front = newest (FIFO)
  std::list<Key> hot;    // pages loaded again, front = most recently used (LRU)
  std::list<Key> ghosts; // keys evicted from `fresh`, front = newest
  std::unordered_map<Key, std::list<Key>::iterator, KeyHash> ghost_index;
  // Pages evicted while someone still held them (a gather's pins), front =
  // newest: a miss of such a page takes it back if it is still alive,
  // instead of loading and decoding a second copy of it.
  std::list<Departed> departed;
  std::unordered_map<Key, std::list<Departed>::iterator, KeyHash> departed_index;
  uint64_t fresh_bytes = 0;
  std::unordered_map<Key, Entry, KeyHash> held;
  std::unordered_map<Key, std::shared_future<tree::PagePtr>, KeyHash> loading;
  CacheCounters counters;
  std::atomic<uint64_t> next_owner{1};

  explicit Impl(uint64_t b) : budget(b) {}

  // Requires mu.
  void remember_ghost(const Key& key) {
    ghosts.push_front(key);
    ghost_index[key] = ghosts.begin();
    const size_t cap = std::max(kMinGhosts, kGhostsPerHeldPage * held.size());
    while (ghosts.size() > cap) {
      ghost_index.erase(ghosts.back());
      ghosts.pop_back();
    }
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

  // Requires mu. Drops one page: from the new pages while they hold more
  // than a quarter of the budget (or nothing is hot), else the least
  // recently used hot page.
  void evict_one() {
    const bool from_fresh = !fresh.empty() && (fresh_bytes > budget / 4 || hot.empty());
    std::list<Key>& list = from_fresh ? fresh : hot;
    const Key victim = list.back();
    list.pop_back();
    auto it = held.find(victim);
    counters.bytes_held -= it->second.bytes;
    // Still used (the cache's reference is not the only one): remembered.
    if (it->second.page.use_count() > 1) remember_departed(victim, it->second.page);
    if (from_fresh) {
      fresh_bytes -= it->second.bytes;
      remember_ghost(victim);
    }
    held.erase(it);
    ++counters.evictions;
  }

  // Requires mu. Holds `page` if it fits the budget.
  void hold(const Key& key, const tree::PagePtr& page, bool was_ghost) {
    const uint64_t bytes = page->memory_bytes() + kEntryBytes;
    if (bytes > budget || held.count(key)) return;
    while (counters.bytes_held + bytes > budget) evict_one();
    std::list<Key>& list = was_ghost ? hot : fresh;
    list.push_front(key);
    held.emplace(key, Entry{page, bytes, was_ghost, list.begin()});
    counters.bytes_held += bytes;
    if (!was_ghost) fresh_bytes += bytes;
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
  std::optional<std::promise<tree::PagePtr>> promise;
  bool was_ghost = false;
  {
    std::unique_lock lock(impl_->mu);
    if (auto it = impl_->held.find(key); it != impl_->held.end()) {
      ++impl_->counters.hits;
      if (it->second.hot) impl_->hot.splice(impl_->hot.begin(), impl_->hot, it->second.pos);
      return it->second.page;
    }
    if (auto it = impl_->loading.find(key); it != impl_->loading.end()) {
      ++impl_->counters.hits;
      auto pending = it->second;
      lock.unlock();
      return pending.get();
    }
    // Evicted while in use and still alive: taken back, no load (a hit).
    // Such a page is in the working set of the gathers in flight: hot.
    if (tree::PagePtr back = impl_->take_departed(key)) {
      ++impl_->counters.hits;
      if (auto g = impl_->ghost_index.find(key); g != impl_->ghost_index.end()) {
        impl_->ghosts.erase(g->second);
        impl_->ghost_index.erase(g);
      }
      impl_->hold(key, back, true);
      return back;
    }
    ++impl_->counters.misses;
    if (auto g = impl_->ghost_index.find(key); g != impl_->ghost_index.end()) {
      was_ghost = true;
      impl_->ghosts.erase(g->second);
      impl_->ghost_index.erase(g);
    }
    promise.emplace();
    impl_->loading.emplace(key, promise->get_future().share());
  }

  // Load outside the lock: I/O and decoding must not block other pages.
  tree::PagePtr page;
  try {
    page = load();
    if (!page) throw Error("page loader returned no page for page " + std::to_string(page_id));
  } catch (...) {
    {
      std::lock_guard lock(impl_->mu);
      impl_->loading.erase(key);
    }
    promise->set_exception(std::current_exception());
    throw;
  }
  {
    std::lock_guard lock(impl_->mu);
    impl_->loading.erase(key);
    impl_->hold(key, page, was_ghost);
  }
  promise->set_value(page);
  return page;
}

void PageCache::note_bytes_read(uint64_t n) {
  std::lock_guard lock(impl_->mu);
  impl_->counters.bytes_read += n;
}

CacheCounters PageCache::counters() const {
  std::lock_guard lock(impl_->mu);
  return impl_->counters;
}

uint64_t PageCache::budget() const {
  std::lock_guard lock(impl_->mu);
  return impl_->budget;
}

void PageCache::set_budget(uint64_t budget_bytes) {
  std::lock_guard lock(impl_->mu);
  impl_->budget = budget_bytes;
  while (impl_->counters.bytes_held > impl_->budget) impl_->evict_one();
}

uint64_t PageCache::new_owner() { return impl_->next_owner.fetch_add(1); }

void PageCache::forget(uint64_t owner) {
  std::lock_guard lock(impl_->mu);
  for (auto it = impl_->held.begin(); it != impl_->held.end();) {
    if (it->first.owner == owner) {
      impl_->counters.bytes_held -= it->second.bytes;
      if (it->second.hot) {
        impl_->hot.erase(it->second.pos);
      } else {
        impl_->fresh_bytes -= it->second.bytes;
        impl_->fresh.erase(it->second.pos);
      }
      it = impl_->held.erase(it);
    } else {
      ++it;
    }
  }
  for (auto it = impl_->departed.begin(); it != impl_->departed.end();) {
    if (it->key.owner == owner) {
      impl_->departed_index.erase(it->key);
      it = impl_->departed.erase(it);
    } else {
      ++it;
    }
  }
  for (auto it = impl_->ghosts.begin(); it != impl_->ghosts.end();) {
    if (it->owner == owner) {
      impl_->ghost_index.erase(*it);
      it = impl_->ghosts.erase(it);
    } else {
      ++it;
    }
  }
}

}  // namespace pbgi::storage
