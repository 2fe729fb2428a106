#include "storage/cache/page_cache.h"

#include "common/errors.h"
#include "storage/cache/frequency_sketch.h"

#include <algorithm>
#include <condition_variable>
#include <deque>
#include <exception>
#include <limits>
#include <mutex>
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

constexpr uint32_t kNil = ~0u;

// Where a slot is: on one of W-TinyLFU's three lists (page_cache.h) for
// held pages, among the departed pages (evicted while in use), or free.
enum List : uint8_t { kWindow, kProbation, kProtected, kLists, kDeparted = kLists, kFree };

// One page the cache knows of: held, or departed (evicted while a gather
// still held it, remembered by a weak reference in Impl::departed). Slots
// live in a deque, addressed by index, and link into their list by index:
// a held page costs the cache one slot and its share of the index, instead
// of a hash node, a bucket and a list node as separate heap blocks.
struct Slot {
  Key key{};
  // In its list; next: the free list's link when free; prev: the index of
  // its entry in Impl::departed when departed.
  uint32_t prev = kNil, next = kNil;
  uint32_t bytes = 0;  // charged while held, kept while departed (a page of 4 GiB or more is not held)
  List list = kFree;
  CachedPtr page;  // held
};
static_assert(sizeof(Slot) <= 48);

// A departed page: its slot and a weak reference to it. Kept in an array
// of their own, not in a list through the slots: the sweep (below) looks
// at several in a row, and their use counts, each in a control block no
// core has touched for a while, then load at once instead of one after
// the other behind each slot's link (three fifths of PageCache::get_value's
// samples at 1/8 of the 2M city when they were a list of slots).
struct Departed {
  uint32_t slot;
  std::weak_ptr<const void> page;
};

// A doubly linked list of slots, front = most recently used.
struct SlotList {
  uint32_t head = kNil, tail = kNil;
  size_t size = 0;
  bool empty() const { return size == 0; }
};

// The frequency sketch's share of a held page. The sketch has fewer than 8
// bytes an item (8 counters of 4 bits, rounded up to a power of two) and
// is sized for twice the pages held when it is resized (fit_sketch()):
// under 16 bytes a page then, less as the holdings grow.
constexpr uint64_t kSketchBytesPerPage = 16;
// The index's share: 4 bytes a bucket, grown to twice its size when more
// than half full, so at most 16 bytes a slot.
constexpr uint64_t kIndexBytesPerPage = 16;

// What holding a page costs the cache itself, charged with the page: its
// slot (the deque allocates slots in blocks) and its shares of the index
// and of the frequency sketch. 80 bytes, a third of a V10 page's bytes on
// disk (docs/out-of-core.md).
constexpr uint64_t kEntryBytes = sizeof(Slot) + kIndexBytesPerPage + kSketchBytesPerPage;

// The window's share of the budget (TinyLFU's 1%): a page used twice in
// quick succession is not judged by its frequency.
constexpr uint64_t kWindowShare = 100;
// The protected list's share of the main part (Caffeine's 80%).
constexpr uint64_t kProtectedPercent = 80;

// Departed pages looked at per miss (sweep_departed()), more than a miss
// departs (it evicts a page or two): a departed page whose last user let
// go is forgotten within (departed pages / 8) misses; counters() looks at
// all.
// Hits, which are most fetches, look at none.
constexpr size_t kSweepPerMiss = 8;

// A load in flight, which the callers that miss the same page wait for.
// Not a std::promise: its set_value() goes through pthread_once, which
// makes a futex system call whether or not anyone waits, on every miss
// (two thirds of the gather's futex calls at 1/8 of the 2M city).
struct Pending {
  CachedPtr page;
  std::exception_ptr error;
  bool done = false;  // guarded by PageCache::Impl::mu
  int waiters = 0;    // guarded by PageCache::Impl::mu
};

}  // namespace

struct PageCache::Impl {
  uint64_t budget;  // guarded by mu (set_budget)
  mutable std::mutex mu;
  std::deque<Slot> slots;
  uint32_t free_slots = kNil;  // chained through Slot::next
  // Open addressing with linear probing: slot indices by key hash, kNil
  // where empty; a power of two in size, at most half full.
  std::vector<uint32_t> index = std::vector<uint32_t>(16, kNil);
  size_t indexed = 0;
  SlotList lists[kLists];
  // The departed pages, in no order; sweep_departed() goes round them from
  // sweep_at.
  std::vector<Departed> departed;
  size_t sweep_at = 0;
  uint64_t window_bytes = 0, protect_bytes = 0;
  FrequencySketch sketch;
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
  std::vector<CachedPtr> released;

  explicit Impl(uint64_t b) : budget(b) {}

  // Requires mu. The pages dropped since the last call, to be destroyed
  // once the lock is released.
  std::vector<CachedPtr> take_released() {
    std::vector<CachedPtr> out;
    out.swap(released);
    return out;
  }

  static uint64_t hash(const Key& key) { return KeyHash{}(key); }
  size_t held_count() const { return lists[kWindow].size + lists[kProbation].size + lists[kProtected].size; }

  // --- index ---
  // Requires mu. The bucket of `key`'s slot, or of the empty bucket where
  // it would go.
  size_t bucket_of(const Key& key) const {
    const size_t mask = index.size() - 1;
    for (size_t b = hash(key) & mask;; b = (b + 1) & mask) {
      if (index[b] == kNil || slots[index[b]].key == key) return b;
    }
  }
  // Requires mu. `key`'s slot, or kNil.
  uint32_t find(const Key& key) const { return index[bucket_of(key)]; }
  void index_insert(uint32_t slot) {
    if (2 * (indexed + 1) > index.size()) {
      std::vector<uint32_t> old(2 * index.size(), kNil);
      old.swap(index);
      for (uint32_t s : old) {
        if (s != kNil) index[bucket_of(slots[s].key)] = s;
      }
    }
    index[bucket_of(slots[slot].key)] = slot;
    ++indexed;
  }
  // Backward-shift deletion: the buckets after the hole that a probe from
  // their home would not reach across it move back into it.
  void index_erase(const Key& key) {
    const size_t mask = index.size() - 1;
    size_t hole = bucket_of(key);
    for (size_t b = (hole + 1) & mask; index[b] != kNil; b = (b + 1) & mask) {
      const size_t home = hash(slots[index[b]].key) & mask;
      // Movable when home is not in the cyclic range (hole, b].
      if (((b - home) & mask) >= ((b - hole) & mask)) {
        index[hole] = index[b];
        hole = b;
      }
    }
    index[hole] = kNil;
    --indexed;
  }

  // --- slots and lists ---
  uint32_t new_slot(const Key& key) {
    uint32_t s = free_slots;
    if (s != kNil) {
      free_slots = slots[s].next;
    } else {
      s = static_cast<uint32_t>(slots.size());
      slots.emplace_back();
    }
    slots[s] = Slot{};
    slots[s].key = key;
    index_insert(s);
    return s;
  }
  void free_slot(uint32_t s) {
    index_erase(slots[s].key);
    Slot& slot = slots[s];
    if (slot.page) released.push_back(std::move(slot.page));
    slot = Slot{};
    slot.next = free_slots;
    free_slots = s;
  }
  void push_front(uint32_t s, List to) {
    Slot& slot = slots[s];
    SlotList& l = lists[to];
    slot.list = to;
    slot.prev = kNil;
    slot.next = l.head;
    if (l.head != kNil) slots[l.head].prev = s;
    l.head = s;
    if (l.tail == kNil) l.tail = s;
    ++l.size;
    if (to == kWindow) window_bytes += slot.bytes;
    if (to == kProtected) protect_bytes += slot.bytes;
  }
  void unlink(uint32_t s) {
    Slot& slot = slots[s];
    SlotList& l = lists[slot.list];
    (slot.prev != kNil ? slots[slot.prev].next : l.head) = slot.next;
    (slot.next != kNil ? slots[slot.next].prev : l.tail) = slot.prev;
    --l.size;
    if (slot.list == kWindow) window_bytes -= slot.bytes;
    if (slot.list == kProtected) protect_bytes -= slot.bytes;
    slot.list = kFree;
    slot.prev = slot.next = kNil;
  }
  // Requires mu. Moves a slot to the front of `to`.
  void move(uint32_t s, List to) {
    unlink(s);
    push_front(s, to);
  }

  // Requires mu. The sketch sized for twice the pages held, resized (its
  // counts forgotten) only when the holdings outgrow it or fall below a
  // quarter of it: under 16 bytes a page held after a resize, under 8 once
  // the holdings have doubled, up to 32 while they shrink to a quarter;
  // and not reset by the ups and downs of a full cache.
  void fit_sketch() {
    const size_t n = held_count();
    if (n > sketch.items() || (n >= 8 && 4 * n < sketch.items())) sketch.resize(2 * n);
  }

  // --- departed pages ---
  // Requires mu. Slot `s`, unlinked, departs: remembered by a weak
  // reference to `page`, its bytes counted in bytes_pinned.
  void depart(uint32_t s, const CachedPtr& page) {
    Slot& slot = slots[s];
    slot.list = kDeparted;
    slot.prev = static_cast<uint32_t>(departed.size());
    departed.push_back({s, page});
    counters.bytes_pinned += slot.bytes;
    counters.bytes_pinned_peak = std::max(counters.bytes_pinned_peak, counters.bytes_pinned);
  }
  // Requires mu. Departed slot `s` is departed no more (taken back, or
  // about to be freed): its entry leaves the array, whose last entry takes
  // its place.
  void undepart(uint32_t s) {
    Slot& slot = slots[s];
    const uint32_t at = slot.prev;
    if (at + 1 != departed.size()) {
      departed[at] = std::move(departed.back());
      slots[departed[at].slot].prev = at;
    }
    departed.pop_back();
    counters.bytes_pinned -= slot.bytes;
    slot.list = kFree;
    slot.prev = kNil;
  }
  // Requires mu. Looks at up to `n` departed pages, going round the array:
  // one whose users all let go is forgotten (its bytes leave
  // bytes_pinned), one still in use is looked at again on the next round.
  void sweep_departed(size_t n) {
    for (; n > 0 && !departed.empty(); --n) {
      if (sweep_at >= departed.size()) sweep_at = 0;
      if (departed[sweep_at].page.expired()) {
        const uint32_t s = departed[sweep_at].slot;
        undepart(s);  // the last entry moves to sweep_at: looked at next
        free_slot(s);
      } else {
        ++sweep_at;
      }
    }
  }
  // Requires mu. Looks at every departed page once: a round from the
  // array's start never wraps (a forgotten page's place takes an entry not
  // looked at yet).
  void sweep_all_departed() {
    sweep_at = 0;
    sweep_departed(departed.size());
  }

  // Requires mu. Evicts held pages, least valued first, while the budget
  // is exceeded.
  void fit_budget() {
    while (counters.bytes_held > budget) evict_one();
  }

  // Requires mu. Drops the held page in slot `s`; `evicted`: counted, and
  // remembered (the slot stays, departed) if still in use.
  void drop(uint32_t s, bool evicted) {
    Slot& slot = slots[s];
    unlink(s);
    counters.bytes_held -= slot.bytes;  // a departed slot keeps its charge, for hold() when taken back
    if (evicted) ++counters.evictions;
    // Still used (the cache's reference is not the only one): remembered.
    if (evicted && slot.page.use_count() > 1) {
      depart(s, slot.page);
      released.push_back(std::move(slot.page));
      return;
    }
    free_slot(s);
  }

  uint64_t window_budget() const { return budget / kWindowShare; }
  uint64_t protect_budget() const { return (budget - window_budget()) / 100 * kProtectedPercent; }

  // Requires mu. A hit: a page used again in probation is protected; the
  // protected pages beyond their share go back to probation, least
  // recently used first.
  void on_hit(uint32_t s) {
    if (slots[s].list == kProbation) {
      move(s, kProtected);
      while (protect_bytes > protect_budget() && lists[kProtected].size > 1) {
        move(lists[kProtected].tail, kProbation);
      }
    } else {
      move(s, slots[s].list);
    }
  }

  // Requires mu. Drops one page, for a smaller budget: the least recently
  // used of probation, else of the protected pages, else of the window.
  void evict_one() {
    const List from = !lists[kProbation].empty() ? kProbation : !lists[kProtected].empty() ? kProtected : kWindow;
    drop(lists[from].tail, true);
  }

  // Requires mu. The pages the window holds beyond its share leave it,
  // oldest first, as candidates for the main part: a candidate is admitted
  // while the budget has room, or by evicting the main part's least
  // recently used page if the candidate is used more often than it; else
  // the candidate is evicted. The window keeps at least its newest page.
  void admit_from_window() {
    while (window_bytes > window_budget() && lists[kWindow].size > 1) {
      const uint32_t candidate = lists[kWindow].tail;
      move(candidate, kProbation);
      while (counters.bytes_held > budget) {
        const bool other_on_probation = lists[kProbation].tail != candidate;
        if (!other_on_probation && lists[kProtected].empty()) break;
        const uint32_t victim = other_on_probation ? lists[kProbation].tail : lists[kProtected].tail;
        if (sketch.estimate(hash(slots[candidate].key)) > sketch.estimate(hash(slots[victim].key))) {
          drop(victim, true);
        } else {
          drop(candidate, true);
          break;
        }
      }
    }
    fit_budget();
  }

  // Requires mu. Holds `page`, charged `page_bytes` (in the window) if it
  // fits the budget; the key's slot, if it has one, is departed.
  void hold(const Key& key, const CachedPtr& page, uint64_t page_bytes) {
    const uint64_t bytes = page_bytes + kEntryBytes;
    if (bytes > budget || bytes > std::numeric_limits<uint32_t>::max()) return;
    uint32_t s = find(key);
    if (s != kNil && slots[s].list != kDeparted) return;  // held already
    if (s != kNil) {
      undepart(s);
    } else {
      s = new_slot(key);
    }
    slots[s].page = page;
    slots[s].bytes = bytes;
    push_front(s, kWindow);
    counters.bytes_held += bytes;
    fit_sketch();
    admit_from_window();
  }
};

uint64_t PageCache::entry_bytes() { return kEntryBytes; }

PageCache::PageCache(uint64_t budget_bytes) : impl_(std::make_unique<Impl>(budget_bytes)) {}
PageCache::~PageCache() = default;

CachedPtr PageCache::get_value(uint64_t owner, uint32_t page_id, const std::function<CachedValue()>& load) {
  const Key key{owner, page_id};
  // Made only on a miss: a hit (every page of every gather, once the cache
  // is warm) allocates nothing.
  std::shared_ptr<Pending> pending;
  {
    std::unique_lock lock(impl_->mu);
    impl_->sketch.add(Impl::hash(key));
    const uint32_t slot = impl_->find(key);
    if (slot != kNil && impl_->slots[slot].list != kDeparted) {
      ++impl_->counters.hits;
      impl_->on_hit(slot);
      return impl_->slots[slot].page;
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
    if (slot != kNil) {
      if (CachedPtr back = impl_->departed[impl_->slots[slot].prev].page.lock()) {
        ++impl_->counters.hits;
        const uint64_t bytes = impl_->slots[slot].bytes - kEntryBytes;
        impl_->hold(key, back, bytes);
        const std::vector<CachedPtr> dropped = impl_->take_released();
        lock.unlock();
        return back;
      }
      impl_->undepart(slot);  // departed and died: forgotten
      impl_->free_slot(slot);
    }
    ++impl_->counters.misses;
    pending = std::make_shared<Pending>();
    impl_->loading.emplace(key, pending);
  }

  // Load outside the lock: I/O and decoding must not block other pages.
  CachedValue page;
  std::exception_ptr error;
  try {
    page = load();
    if (!page.value) throw Error("page loader returned no page for page " + std::to_string(page_id));
  } catch (...) {
    error = std::current_exception();
  }
  std::vector<CachedPtr> dropped;  // released after the lock
  bool wake = false;
  {
    std::lock_guard lock(impl_->mu);
    impl_->loading.erase(key);
    if (!error) {
      impl_->sweep_departed(kSweepPerMiss);
      impl_->hold(key, page.value, page.bytes);  // nothing is cached for a failed load
      dropped = impl_->take_released();
    }
    pending->page = page.value;
    pending->error = error;
    pending->done = true;
    wake = pending->waiters > 0;
  }
  if (wake) impl_->loaded.notify_all();
  if (error) std::rethrow_exception(error);
  return page.value;
}

tree::PagePtr PageCache::get(uint64_t owner, uint32_t page_id, const std::function<tree::PagePtr()>& load) {
  return std::static_pointer_cast<const tree::Page>(get_value(owner, page_id, [&]() -> CachedValue {
    tree::PagePtr page = load();
    const uint64_t bytes = page ? page->memory_bytes() : 0;
    return {std::move(page), bytes};
  }));
}

void PageCache::note_bytes_read(uint64_t n) { impl_->bytes_read.fetch_add(n, std::memory_order_relaxed); }

CacheCounters PageCache::counters() const {
  std::lock_guard lock(impl_->mu);
  // Every departed page looked at (a forgotten one holds no page to
  // release): bytes_pinned is what gathers pin now.
  impl_->sweep_all_departed();
  CacheCounters c = impl_->counters;
  c.bytes_read = impl_->bytes_read.load(std::memory_order_relaxed);
  return c;
}

uint64_t PageCache::budget() const {
  std::lock_guard lock(impl_->mu);
  return impl_->budget;
}

void PageCache::set_budget(uint64_t budget_bytes) {
  std::vector<CachedPtr> dropped;  // released after the lock
  std::lock_guard lock(impl_->mu);
  impl_->budget = budget_bytes;
  impl_->fit_budget();
  impl_->fit_sketch();
  dropped = impl_->take_released();
}

uint64_t PageCache::new_owner() { return impl_->next_owner.fetch_add(1); }

void PageCache::forget(uint64_t owner) {
  std::vector<CachedPtr> dropped;  // released after the lock
  std::lock_guard lock(impl_->mu);
  for (uint32_t s = 0; s < impl_->slots.size(); ++s) {
    Slot& slot = impl_->slots[s];
    if (slot.list == kFree || slot.key.owner != owner) continue;
    if (slot.list == kDeparted) {
      impl_->undepart(s);
      impl_->free_slot(s);
    } else {
      impl_->drop(s, false);
    }
  }
  impl_->fit_sketch();
  dropped = impl_->take_released();
}

}  // namespace pbgi::storage
