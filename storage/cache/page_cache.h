// Cache of decoded pages with a hard byte budget, shared by all page sets of
// the daemon. Thread-safe. Pages in use by a gather stay alive through their
// shared_ptr even if evicted, so the budget bounds the cache's own holdings.
#pragma once

#include "storage/tree/node.h"

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>

namespace pbgi::storage {

struct CacheCounters {
  uint64_t hits = 0, misses = 0, evictions = 0, bytes_read = 0, bytes_held = 0;
};

class PageCache {
 public:
  explicit PageCache(uint64_t budget_bytes);
  ~PageCache();

  // Returns the page keyed (owner, page_id), calling `load` on a miss.
  // `owner` identifies the page set (distinct per open reader).
  tree::PagePtr get(uint64_t owner, uint32_t page_id,
                    const std::function<tree::PagePtr()>& load);
  void note_bytes_read(uint64_t n);
  CacheCounters counters() const;
  uint64_t budget() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace pbgi::storage
