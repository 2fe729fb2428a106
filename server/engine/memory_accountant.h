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
// A scene is charged from its first chunk on: while it is read its
// geometry grows chunk by chunk, each growth charged before it is allocated
// (ChargeKind::kRead, server/ingest/scene_read_memory.h); once read, the
// same charge becomes the scene's (kScene) and a build adds its working
// memory (kBuild) while it runs. The totals by kind are reported (GetStatus,
// the Prometheus metrics).
//
// Not counted (the overhead docs/memory-budget.md states): code and static
// data, allocator slack and fragmentation, gRPC's and TBB's own buffers and
// thread stacks, pages a gather holds after the cache evicted them, the
// USD reader process (another process), one stream frame and one refined
// subdivision mesh while a scene is read, textures.
//
// Thread-safe. Charges keep the accountant alive (shared_ptr): a session
// may outlive the daemon's reference to it.
#pragma once

#include "storage/cache/page_cache.h"

#include <algorithm>
#include <array>
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
  // The most the page cache may hold, whatever the charges leave it (0 =
  // no cap): a cache of a known size within a larger budget (measuring a
  // cache of 1/8 of a page set while scenes are charged their estimates).
  uint64_t cache_limit = 0;
  // What charges may hold together: total - request_reserve - cache_floor.
  // Throws InvalidArgument naming the three if that is not positive.
  uint64_t chargeable() const;
};

// What charged bytes pay for, totalled apart by the accountant.
enum class ChargeKind : uint8_t {
  kScene = 0,  // an open scene: geometry + ray-tracing structure
  kRead = 1,   // a scene's geometry while it is read (decoded, stored, reloaded)
  kBuild = 2,  // a page-set build's working memory while it runs
};
inline constexpr size_t kChargeKinds = 3;

// The accountant's state at one moment (GetStatus, metrics).
struct MemoryUsage {
  MemoryBudget budget;
  std::array<uint64_t, kChargeKinds> charged{};  // by ChargeKind
  uint64_t cache_budget = 0;                     // the page cache's share now
  uint64_t refusals = 0;                         // charges refused since start
  uint64_t charged_total() const { return charged[0] + charged[1] + charged[2]; }
};

class MemoryAccountant;

// Bytes charged to the accountant, released on destruction. Move-only.
// A charge has a part per ChargeKind (a scene's one charge holds its read,
// then its geometry and ray structure, and its build's memory beside
// them while the build runs). Not thread-safe itself (one owner), but any
// number of charges may change concurrently.
class MemoryCharge {
 public:
  MemoryCharge() = default;
  MemoryCharge(MemoryCharge&& other) noexcept;
  MemoryCharge& operator=(MemoryCharge&& other) noexcept;
  MemoryCharge(const MemoryCharge&) = delete;
  MemoryCharge& operator=(const MemoryCharge&) = delete;
  ~MemoryCharge();

  uint64_t bytes() const { return parts_[0] + parts_[1] + parts_[2]; }
  uint64_t bytes(ChargeKind kind) const { return parts_[size_t(kind)]; }
  // Sets the charge's `kind` part to `bytes` (an estimate replaced by a
  // measured size, a build's working memory added or given back, a scene
  // being read grown by a chunk). Growing may unload idle scenes and shrink
  // the page cache, and throws ResourceExhausted as MemoryAccountant::
  // charge() does (the charge is then unchanged); shrinking always succeeds
  // and grows the page cache. `what` names the growth in the error
  // ("ray-tracing structure (estimated)").
  void resize(ChargeKind kind, uint64_t bytes, const std::string& what);
  void resize(uint64_t bytes, const std::string& what) { resize(ChargeKind::kScene, bytes, what); }
  // Moves the `from` part to `to` (a scene read becomes a scene open):
  // the total, hence the budget, is unchanged.
  void reclassify(ChargeKind from, ChargeKind to) noexcept;
  void release() noexcept;

 private:
  friend class MemoryAccountant;
  MemoryCharge(std::shared_ptr<MemoryAccountant> accountant, std::string owner, ChargeKind kind, uint64_t bytes);
  std::shared_ptr<MemoryAccountant> accountant_;
  std::string owner_;  // the scene path, for errors and logs
  std::array<uint64_t, kChargeKinds> parts_{};
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

  // Charges `bytes` of `kind` for `owner` (a scene path), `what` naming
  // them in the error. Throws ResourceExhausted naming owner, what, the
  // bytes needed and the budget if they cannot fit even with every idle
  // scene unloaded and the page cache at its floor. A charge of 0 bytes
  // always succeeds (a read about to start).
  MemoryCharge charge(const std::string& owner, const std::string& what, uint64_t bytes,
                      ChargeKind kind = ChargeKind::kScene);

  const MemoryBudget& budget() const { return budget_; }
  uint64_t charged() const;  // held by charges now
  // What one more charge could take now without unloading anything.
  uint64_t available() const;
  uint64_t cache_budget() const;  // the page cache's share now
  uint64_t refusals() const;      // charges refused since start
  MemoryUsage usage() const;      // all of the above at one moment

 private:
  MemoryAccountant(MemoryBudget budget, std::shared_ptr<storage::PageCache> cache);
  friend class MemoryCharge;
  // Takes `more` bytes of `kind` for `owner` (whose charge is `held` now);
  // throws as charge() does.
  void grow(const std::string& owner, const std::string& what, uint64_t held, uint64_t more, ChargeKind kind);
  void give_back(ChargeKind kind, uint64_t bytes) noexcept;
  void move_kind(ChargeKind from, ChargeKind to, uint64_t bytes) noexcept;
  // Requires mutex_.
  void resize_cache_locked();
  // What the budget leaves the page cache: total less the request reserve
  // and every charge, at most cache_limit. Callers hold mutex_.
  uint64_t cache_budget_locked() const {
    const uint64_t left = budget_.total - budget_.request_reserve - charged_;
    return budget_.cache_limit ? std::min(left, budget_.cache_limit) : left;
  }

  const MemoryBudget budget_;
  const std::shared_ptr<storage::PageCache> cache_;
  mutable std::mutex mutex_;
  Reclaimer reclaimer_;
  uint64_t charged_ = 0;  // sum of by_kind_
  std::array<uint64_t, kChargeKinds> by_kind_{};
  uint64_t refusals_ = 0;
};

}  // namespace pbgi
