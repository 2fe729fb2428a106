// Thread-safe progress reporting for parallel loops: reports a stage's
// fraction each time it crosses another percent, from whichever worker
// crossed it, serialized so the callback sees increasing fractions.
#pragma once

#include "server/surfels/surfels.h"

#include <atomic>
#include <cstdint>
#include <mutex>

namespace pbgi {

class ProgressMeter {
 public:
  ProgressMeter(const ProgressFn& fn, const char* stage, uint64_t total)
      : fn_(fn), stage_(stage), total_(total) {
    if (fn_) fn_(stage_, 0.f);
  }

  // Marks n more items done. Thread-safe; cheap unless a percent is crossed.
  void advance(uint64_t n) {
    if (!fn_ || total_ == 0) return;
    const uint64_t done = done_.fetch_add(n, std::memory_order_relaxed) + n;
    const int percent = static_cast<int>(done * 100 / total_);
    if (percent <= reported_.load(std::memory_order_relaxed)) return;
    std::lock_guard<std::mutex> lock(mutex_);
    if (percent <= reported_.load(std::memory_order_relaxed)) return;
    reported_.store(percent, std::memory_order_relaxed);
    if (percent < 100) fn_(stage_, static_cast<float>(percent) / 100.f);
  }

  // Reports 1.0 exactly once, after the loop.
  void finish() {
    if (fn_) fn_(stage_, 1.f);
  }

 private:
  const ProgressFn& fn_;
  const char* stage_;
  uint64_t total_;
  std::atomic<uint64_t> done_{0};
  std::atomic<int> reported_{0};
  std::mutex mutex_;
};

}  // namespace pbgi
