// The daemon's one memory budget (--memory-budget), and who holds what of it.
//
// The budget is split, as RocksDB charges its memtables to the block
// cache's budget (WriteBufferManager):
//   request reserve   a fixed share for the requests in flight (messages,
//                     receivers, results); admission (limits.max_in_flight)
//                     keeps them within it;
//   charges           each open scene's geometry and ray-tracing structure,
//                     and a build's working memory while it runs: charged
//                     from an estimate before they are allocated, then set
//                     to their measured size;
//   page cache        what remains (storage/cache/page_cache.h): it shrinks,
//                     evicting, when a charge grows and grows back when one
//                     is released, never below its floor.
// A charge that does not fit first has the reclaimer unload idle scenes
// (the scene registry: least recently used first, none a request holds),
// then takes the page cache down to its floor; if it still does not fit it
// is refused with ResourceExhausted naming what it was for, the bytes it
// needs and what the budget can give, before anything is allocated.
//
// Not counted (the overhead docs/out-of-core.md states): code and static
// data, allocator slack and fragmentation, gRPC's and TBB's own buffers and
// thread stacks, pages a gather holds after the cache evicted them, the
// USD reader process (another process) and a scene's geometry while it is
// read (charged once read).
//
// Thread-safe. Charges keep the accountant alive (shared_ptr): a session
// may outlive the daemon's reference to it.
#pragma once

#include "storage/cache/page_cache.h"

#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>

namespace pbgi {

struct MemoryBudget {
  uint64_t total = 0;            // the whole budget, bytes
  uint64_t request_reserve = 0;  // kept for requests in flight
  uint64_t cache_floor = 0;      // the page cache is never shrunk below it
  // What charges may hold together: total - request_reserve - cache_floor.
  // Throws InvalidArgument naming the three if that is not positive.
  uint64_t chargeable() const;
};

class MemoryAccountant;

// Bytes charged to the accountant, released on destruction. Move-only.
// Not thread-safe itself (one owner), but any number of charges may change
// concurrently.
class MemoryCharge {
 public:
  MemoryCharge() = default;
  MemoryCharge(MemoryCharge&& other) noexcept;
  MemoryCharge& operator=(MemoryCharge&& other) noexcept;
  MemoryCharge(const MemoryCharge&) = delete;
  MemoryCharge& operator=(const MemoryCharge&) = delete;
  ~MemoryCharge();

  uint64_t bytes() const { return bytes_; }
  // Sets the charge to `bytes` (an estimate replaced by a measured size, a
  // build's working memory added or given back). Growing may unload idle
  // scenes and shrink the page cache, and throws ResourceExhausted as
  // MemoryAccountant::charge() does (the charge is then unchanged);
  // shrinking always succeeds and grows the page cache. `what` names the
  // growth in the error ("ray-tracing structure (estimated)").
  void resize(uint64_t bytes, const std::string& what);
  void release() noexcept;

 private:
  friend class MemoryAccountant;
  MemoryCharge(std::shared_ptr<MemoryAccountant> accountant, std::string owner, uint64_t bytes);
  std::shared_ptr<MemoryAccountant> accountant_;
  std::string owner_;  // the scene path, for errors and logs
  uint64_t bytes_ = 0;
};

class MemoryAccountant : public std::enable_shared_from_this<MemoryAccountant> {
 public:
  // Unloads idle scenes to free `bytes` (what the charge lacks); returns true if it
  // unloaded any (their charges are released as their sessions go), false
  // if nothing more can be unloaded.
  using Reclaimer = std::function<bool(uint64_t bytes)>;

  // `cache` (may be null: nothing to shrink) gets total - request_reserve
  // at once. Throws InvalidArgument for a budget without chargeable bytes.
  static std::shared_ptr<MemoryAccountant> create(MemoryBudget budget, std::shared_ptr<storage::PageCache> cache);

  // Installed once by the scene registry; called without the accountant's
  // lock held (the sessions it unloads release their charges).
  void set_reclaimer(Reclaimer reclaimer);

  // Charges `bytes` for `owner` (a scene path), `what` naming them in the
  // error. Throws ResourceExhausted naming owner, what, the bytes needed
  // and the budget if they cannot fit even with every idle scene unloaded
  // and the page cache at its floor.
  MemoryCharge charge(const std::string& owner, const std::string& what, uint64_t bytes);

  const MemoryBudget& budget() const { return budget_; }
  uint64_t charged() const;  // held by charges now
  // What one more charge could take now without unloading anything.
  uint64_t available() const;
  uint64_t cache_budget() const;  // the page cache's share now
  uint64_t refusals() const;      // charges refused since start

 private:
  MemoryAccountant(MemoryBudget budget, std::shared_ptr<storage::PageCache> cache);
  friend class MemoryCharge;
  // Takes `more` bytes for `owner` (whose charge is `held` now); throws as
  // charge() does.
  void grow(const std::string& owner, const std::string& what, uint64_t held, uint64_t more);
  void give_back(uint64_t bytes) noexcept;
  // Requires mutex_.
  void resize_cache_locked();

  const MemoryBudget budget_;
  const std::shared_ptr<storage::PageCache> cache_;
  mutable std::mutex mutex_;
  Reclaimer reclaimer_;
  uint64_t charged_ = 0;
  uint64_t refusals_ = 0;
};

}  // namespace pbgi
