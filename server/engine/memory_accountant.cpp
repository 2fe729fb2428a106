#include "server/engine/memory_accountant.h"

#include "common/errors.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <utility>

namespace pbgi {
namespace {

double mib(uint64_t bytes) { return double(bytes) / double(1 << 20); }

}  // namespace

uint64_t MemoryBudget::chargeable() const {
  if (request_reserve >= total || cache_floor >= total - request_reserve) {
    throw InvalidArgument(
        fmt::format("memory_budget {} bytes leaves nothing for scenes after request_memory {} and page_cache_floor {}",
                    total, request_reserve, cache_floor));
  }
  return total - request_reserve - cache_floor;
}

// ---- MemoryCharge ----

MemoryCharge::MemoryCharge(std::shared_ptr<MemoryAccountant> accountant, std::string owner, ChargeKind kind,
                           uint64_t bytes)
    : accountant_(std::move(accountant)), owner_(std::move(owner)) {
  parts_[size_t(kind)] = bytes;
}

MemoryCharge::MemoryCharge(MemoryCharge&& other) noexcept
    : accountant_(std::move(other.accountant_)),
      owner_(std::move(other.owner_)),
      parts_(std::exchange(other.parts_, {})) {}

MemoryCharge& MemoryCharge::operator=(MemoryCharge&& other) noexcept {
  if (this != &other) {
    release();
    accountant_ = std::move(other.accountant_);
    owner_ = std::move(other.owner_);
    parts_ = std::exchange(other.parts_, {});
  }
  return *this;
}

MemoryCharge::~MemoryCharge() { release(); }

void MemoryCharge::resize(ChargeKind kind, uint64_t bytes, const std::string& what) {
  if (!accountant_) throw Error(fmt::format("resizing an empty memory charge ({})", what));
  uint64_t& part = parts_[size_t(kind)];
  if (bytes > part) {
    accountant_->grow(owner_, what, this->bytes(), bytes - part, kind);
  } else {
    accountant_->give_back(kind, part - bytes);
  }
  part = bytes;
}

void MemoryCharge::reclassify(ChargeKind from, ChargeKind to) noexcept {
  if (!accountant_ || from == to) return;
  accountant_->move_kind(from, to, parts_[size_t(from)]);
  parts_[size_t(to)] += std::exchange(parts_[size_t(from)], 0);
}

void MemoryCharge::release() noexcept {
  if (accountant_) {
    for (size_t k = 0; k < kChargeKinds; ++k)
      if (parts_[k] > 0) accountant_->give_back(ChargeKind(k), parts_[k]);
  }
  parts_ = {};
}

// ---- MemoryAccountant ----

std::shared_ptr<MemoryAccountant> MemoryAccountant::create(MemoryBudget budget,
                                                           std::shared_ptr<storage::PageCache> cache) {
  budget.chargeable();  // throws for a budget with no room for scenes
  return std::shared_ptr<MemoryAccountant>(new MemoryAccountant(budget, std::move(cache)));
}

MemoryAccountant::MemoryAccountant(MemoryBudget budget, std::shared_ptr<storage::PageCache> cache)
    : budget_(budget), cache_(std::move(cache)) {
  std::lock_guard lock(mutex_);
  resize_cache_locked();
}

void MemoryAccountant::set_reclaimer(Reclaimer reclaimer) {
  std::lock_guard lock(mutex_);
  reclaimer_ = std::move(reclaimer);
}

MemoryCharge MemoryAccountant::charge(const std::string& owner, const std::string& what, uint64_t bytes,
                                      ChargeKind kind) {
  grow(owner, what, 0, bytes, kind);
  return MemoryCharge(shared_from_this(), owner, kind, bytes);
}

void MemoryAccountant::grow(const std::string& owner, const std::string& what, uint64_t held, uint64_t more,
                            ChargeKind kind) {
  const uint64_t limit = budget_.chargeable();
  bool reclaimed = false;
  for (;;) {
    Reclaimer reclaimer;
    uint64_t shortfall = 0;
    {
      std::lock_guard lock(mutex_);
      // Fits beside the other charges (the cache gives way down to its floor).
      if (held + more <= limit && charged_ + more <= limit) {
        charged_ += more;
        by_kind_[size_t(kind)] += more;
        resize_cache_locked();
        if (reclaimed)
          spdlog::info("'{}': room for {:.1f} MiB of {} made by unloading idle scenes", owner, mib(more), what);
        return;
      }
      // Could fit if others gave way: ask the reclaimer, outside the lock
      // (the sessions it unloads release their charges through it).
      if (held + more <= limit) {
        reclaimer = reclaimer_;
        shortfall = charged_ + more - limit;
      }
      if (!reclaimer) ++refusals_;
    }
    if (reclaimer && reclaimer(shortfall)) {
      reclaimed = true;
      continue;
    }
    if (reclaimer) {
      std::lock_guard lock(mutex_);
      ++refusals_;
    }
    const uint64_t others = charged() - held;
    const std::string needs = held == 0 ? fmt::format("{:.1f} MiB ({} bytes) of {}", mib(more), more, what)
                                        : fmt::format("{:.1f} MiB ({} bytes: {:.1f} MiB held + {:.1f} MiB of {})",
                                                      mib(held + more), held + more, mib(held), mib(more), what);
    throw ResourceExhausted(fmt::format(
        "scene '{}' does not fit in the daemon's memory_budget: it needs {}; the budget of {:.1f} MiB gives "
        "scenes at most {:.1f} MiB (after request_memory {:.1f} MiB and page_cache_floor {:.1f} MiB), and "
        "other scenes in use hold {:.1f} MiB",
        owner, needs, mib(budget_.total), mib(limit), mib(budget_.request_reserve), mib(budget_.cache_floor),
        mib(others)));
  }
}

void MemoryAccountant::give_back(ChargeKind kind, uint64_t bytes) noexcept {
  std::lock_guard lock(mutex_);
  charged_ -= std::min(charged_, bytes);
  uint64_t& part = by_kind_[size_t(kind)];
  part -= std::min(part, bytes);
  resize_cache_locked();
}

void MemoryAccountant::move_kind(ChargeKind from, ChargeKind to, uint64_t bytes) noexcept {
  std::lock_guard lock(mutex_);
  uint64_t& source = by_kind_[size_t(from)];
  const uint64_t moved = std::min(source, bytes);
  source -= moved;
  by_kind_[size_t(to)] += moved;
}

void MemoryAccountant::resize_cache_locked() {
  if (cache_) cache_->set_budget(budget_.total - budget_.request_reserve - charged_);
}

uint64_t MemoryAccountant::charged() const {
  std::lock_guard lock(mutex_);
  return charged_;
}

uint64_t MemoryAccountant::available() const {
  const uint64_t limit = budget_.chargeable();
  std::lock_guard lock(mutex_);
  return limit - std::min(limit, charged_);
}

uint64_t MemoryAccountant::cache_budget() const {
  std::lock_guard lock(mutex_);
  return budget_.total - budget_.request_reserve - charged_;
}

uint64_t MemoryAccountant::refusals() const {
  std::lock_guard lock(mutex_);
  return refusals_;
}

MemoryUsage MemoryAccountant::usage() const {
  std::lock_guard lock(mutex_);
  MemoryUsage u;
  u.budget = budget_;
  u.charged = by_kind_;
  u.cache_budget = budget_.total - budget_.request_reserve - charged_;
  u.refusals = refusals_;
  return u;
}

}  // namespace pbgi
