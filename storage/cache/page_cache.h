// Cache of decoded pages (or of what a reader keeps of them: a page set
// reader with a page decorator keeps only the decorator's attachment,
// storage/pages/page_set.h) with a hard byte budget, shared by all page sets of
// the daemon. Thread-safe. Pages in use by a gather stay alive through their
// shared_ptr even if evicted: the budget bounds the cache's own holdings,
// and the pages evicted while in use are memory beyond it (bytes_pinned;
// what a gather pins is bounded by the gather, server/gather/page_pins.h
// and factorized_gather.cpp).
//
// Policy: W-TinyLFU (Einziger, Friedman & Manes 2017, as Caffeine has it).
// A page that comes enters a small window (1% of the budget, LRU). Pages
// leaving the window are candidates for the main part, an SLRU of
// probation (used once since they came) and protected pages (used again;
// 80% of the main part): a candidate is admitted when there is room, or
// when a frequency sketch (frequency_sketch.h: every get() of a page
// counts, aged by halving) says it is used more often than the page it
// would evict, the least recently used on probation. So the pages most
// gathers need (the top of the tree, the far field every tile sees) stay
// when the pages a render touches exceed the budget, where a plain LRU,
// and the 2Q this replaced, cycle the whole budget through pages used
// once per batch of receivers (2M-surfel city at 1/8 of its page set:
// 46% of fetches hit with 2Q, 60% in a replay of the same fetches through
// W-TinyLFU; docs/out-of-core.md).
//
// One mutex; the critical section is an index probe and list relinks,
// never I/O or decoding. Pages are kept in slots (a deque, linked into the
// lists by index) found through an open-addressing index, so holding a
// page costs the cache no heap block of its own. The bytes of a page are
// what its loader says it costs (Page::memory_bytes() for get()) plus what
// holding it costs the cache (entry_bytes():
// its slot and its shares of the index and of the frequency sketch, 80
// bytes); the cache never holds more than budget() bytes (a page larger
// than the budget is returned but not held; budget 0 holds nothing).
// Concurrent misses of one page call `load` once: the other callers wait
// for that load and share its result (or its exception).
//
// A page evicted while still in use (a gather holds it pinned) is
// remembered by a weak reference: a later miss of it takes that page back
// (held again, as a page that just came) instead of loading and decoding a second copy, so
// concurrent gathers whose pinned pages exceed the budget share them.
// Every miss looks at a few of these departed pages, oldest first, and
// forgets those whose last user let go (counters() looks at all).
//
// Counters: hits (served without calling load, including waiting on another
// caller's load and taking back a page evicted while in use), misses (calls of load), evictions (pages dropped to stay
// within the budget; forget() does not count), bytes_read (as reported by
// loaders through note_bytes_read), bytes_held (current holdings),
// bytes_pinned (evicted, still in use: beyond the budget) and its peak.
#pragma once

#include "storage/tree/node.h"

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>

namespace pbgi::storage {

// What the cache holds for a page: a tree::Page (get()) or whatever else
// its owner keeps of it (get_value()); one owner keeps one kind.
using CachedPtr = std::shared_ptr<const void>;
// A loaded value and the bytes of memory it costs.
struct CachedValue {
  CachedPtr value;
  uint64_t bytes = 0;
};

struct CacheCounters {
  uint64_t hits = 0, misses = 0, evictions = 0, bytes_read = 0, bytes_held = 0;
  // Pages evicted while a gather still holds them (pinned): memory beyond
  // the budget until their last user lets go; and the most there was.
  uint64_t bytes_pinned = 0, bytes_pinned_peak = 0;
};

class PageCache {
 public:
  explicit PageCache(uint64_t budget_bytes);
  ~PageCache();

  // Returns the page keyed (owner, page_id), calling `load` on a miss.
  // `owner` identifies the page set (distinct per open reader).
  // Exceptions of `load` propagate to every caller waiting on that load;
  // nothing is cached for a failed load.
  tree::PagePtr get(uint64_t owner, uint32_t page_id,
                    const std::function<tree::PagePtr()>& load);
  // The same for any value: `load` returns it with its bytes. The caller
  // casts the result back to the type its loads return.
  CachedPtr get_value(uint64_t owner, uint32_t page_id, const std::function<CachedValue()>& load);
  void note_bytes_read(uint64_t n);
  CacheCounters counters() const;
  uint64_t budget() const;
  // The cache's own bytes per page held, charged with the page's.
  static uint64_t entry_bytes();
  // Changes the budget; a smaller one evicts (as the policy above would)
  // until the holdings fit it. The daemon's memory accountant moves it as
  // scenes come and go (server/engine/memory_accountant.h).
  void set_budget(uint64_t budget_bytes);

  // A fresh owner id, distinct from all others this cache has handed out.
  uint64_t new_owner();
  // Drops every page held for `owner` (a reader that closes).
  void forget(uint64_t owner);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace pbgi::storage
