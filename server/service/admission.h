// Back-pressure for the expensive calls (Gather, RenderTile, each tile of
// RenderTiles): at most `max_in_flight` run at once, at most `max_queued`
// more wait for a slot, and anything beyond is refused at once with a hint
// of when to come back, instead of piling up threads and memory until the
// daemon falls over. The work itself runs on the shared TBB pool (bounded
// by the daemon's `threads`); this gate bounds how many requests compete
// for it, so that each finishes in a predictable time.
#pragma once

#include "common/errors.h"

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>

namespace pbgi::service {

// Refused by the gate (gRPC RESOURCE_EXHAUSTED with trailing metadata
// "retry-after-ms").
struct Overloaded : Error {
  Overloaded(const std::string& message, uint32_t retry_after_ms)
      : Error(message), retry_after_ms(retry_after_ms) {}
  uint32_t retry_after_ms;
};

struct AdmissionCounters {
  uint32_t in_flight = 0, queued = 0, max_in_flight = 0, max_queued = 0;
  uint64_t completed = 0, rejected = 0;
};

// Thread-safe.
class AdmissionGate {
 public:
  // max_in_flight >= 1; max_queued may be 0 (refuse as soon as all slots
  // are busy).
  AdmissionGate(uint32_t max_in_flight, uint32_t max_queued);

  // Holds one slot until destroyed; records the time it was held.
  class Ticket {
   public:
    Ticket(Ticket&& other) noexcept;
    Ticket& operator=(Ticket&&) = delete;
    ~Ticket();

   private:
    friend class AdmissionGate;
    Ticket(AdmissionGate* gate) : gate_(gate), start_(std::chrono::steady_clock::now()) {}
    AdmissionGate* gate_;
    std::chrono::steady_clock::time_point start_;
  };

  // Takes a slot, waiting in the queue if all are busy. Throws Overloaded
  // if the queue is full, Cancelled if `cancelled` turns true or
  // `deadline` passes while waiting (checked every few milliseconds).
  Ticket enter(std::chrono::system_clock::time_point deadline,
               const std::function<bool()>& cancelled = {});

  AdmissionCounters counters() const;

  // The hint given with Overloaded: the expected wait for a slot, from the
  // recent mean time a slot is held, in [10 ms, 30 s].
  uint32_t retry_after_ms() const;

 private:
  void leave(std::chrono::steady_clock::duration held);
  uint32_t retry_after_ms_locked() const;

  mutable std::mutex mutex_;
  std::condition_variable freed_;
  const uint32_t max_in_flight_, max_queued_;
  uint32_t in_flight_ = 0, queued_ = 0;
  uint64_t completed_ = 0, rejected_ = 0;
  double mean_held_ms_ = 50.0;   // exponential moving average
};

}  // namespace pbgi::service
