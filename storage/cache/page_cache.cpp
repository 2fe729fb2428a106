#include "storage/cache/page_cache.h"

#include "storage/format/errors.h"

#include <future>
#include <list>
#include <mutex>
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
  std::list<Key>::iterator lru;
};

}  // namespace

struct PageCache::Impl {
  const uint64_t budget;
  mutable std::mutex mu;
  std::list<Key> lru;  // front: most recently used
  std::unordered_map<Key, Entry, KeyHash> held;
  std::unordered_map<Key, std::shared_future<tree::PagePtr>, KeyHash> loading;
  CacheCounters counters;
  std::atomic<uint64_t> next_owner{1};

  explicit Impl(uint64_t b) : budget(b) {}

  // Requires mu. Holds `page` if it fits the budget, evicting LRU pages.
  void hold(const Key& key, const tree::PagePtr& page) {
    const uint64_t bytes = page->memory_bytes();
    if (bytes > budget || held.count(key)) return;
    while (counters.bytes_held + bytes > budget) {
      const Key victim = lru.back();
      auto it = held.find(victim);
      counters.bytes_held -= it->second.bytes;
      held.erase(it);
      lru.pop_back();
      ++counters.evictions;
    }
    lru.push_front(key);
    held.emplace(key, Entry{page, bytes, lru.begin()});
    counters.bytes_held += bytes;
  }
};

PageCache::PageCache(uint64_t budget_bytes) : impl_(std::make_unique<Impl>(budget_bytes)) {}
PageCache::~PageCache() = default;

tree::PagePtr PageCache::get(uint64_t owner, uint32_t page_id,
                             const std::function<tree::PagePtr()>& load) {
  const Key key{owner, page_id};
  std::promise<tree::PagePtr> promise;
  {
    std::unique_lock lock(impl_->mu);
    if (auto it = impl_->held.find(key); it != impl_->held.end()) {
      ++impl_->counters.hits;
      impl_->lru.splice(impl_->lru.begin(), impl_->lru, it->second.lru);
      return it->second.page;
    }
    if (auto it = impl_->loading.find(key); it != impl_->loading.end()) {
      ++impl_->counters.hits;
      auto pending = it->second;
      lock.unlock();
      return pending.get();
    }
    ++impl_->counters.misses;
    impl_->loading.emplace(key, promise.get_future().share());
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
    promise.set_exception(std::current_exception());
    throw;
  }
  {
    std::lock_guard lock(impl_->mu);
    impl_->loading.erase(key);
    impl_->hold(key, page);
  }
  promise.set_value(page);
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

uint64_t PageCache::budget() const { return impl_->budget; }

uint64_t PageCache::new_owner() { return impl_->next_owner.fetch_add(1); }

void PageCache::forget(uint64_t owner) {
  std::lock_guard lock(impl_->mu);
  for (auto it = impl_->held.begin(); it != impl_->held.end();) {
    if (it->first.owner == owner) {
      impl_->counters.bytes_held -= it->second.bytes;
      impl_->lru.erase(it->second.lru);
      it = impl_->held.erase(it);
    } else {
      ++it;
    }
  }
}

}  // namespace pbgi::storage
