#include "server/service/admission.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace pbgi::service {

AdmissionGate::AdmissionGate(uint32_t max_in_flight, uint32_t max_queued)
    : max_in_flight_(std::max<uint32_t>(1, max_in_flight)), max_queued_(max_queued) {}

AdmissionGate::Ticket::Ticket(Ticket&& other) noexcept
    : gate_(other.gate_), start_(other.start_) {
  other.gate_ = nullptr;
}

AdmissionGate::Ticket::~Ticket() {
  if (gate_) gate_->leave(std::chrono::steady_clock::now() - start_);
}

AdmissionGate::Ticket AdmissionGate::enter(std::chrono::system_clock::time_point deadline,
                                           const std::function<bool()>& cancelled) {
  std::unique_lock lock(mutex_);
  if (in_flight_ < max_in_flight_ && queued_ == 0) {
    ++in_flight_;
    return Ticket(this);
  }
  if (queued_ >= max_queued_) {
    ++rejected_;
    const uint32_t hint = retry_after_ms_locked();
    throw Overloaded(fmt::format("daemon overloaded: {} requests running and {} queued (limits "
                                 "{} and {}); retry in {} ms",
                                 in_flight_, queued_, max_in_flight_, max_queued_, hint),
                     hint);
  }
  // Wait in the queue. Waiters are woken one per freed slot; the periodic
  // wake-up only notices a client that left or a deadline that passed.
  ++queued_;
  for (;;) {
    freed_.wait_for(lock, std::chrono::milliseconds(5));
    if (in_flight_ < max_in_flight_) {
      --queued_;
      ++in_flight_;
      return Ticket(this);
    }
    const bool expired = std::chrono::system_clock::now() >= deadline;
    if (expired || (cancelled && cancelled())) {
      --queued_;
      throw Cancelled(expired ? "deadline passed while queued for a worker"
                              : "client went away while queued for a worker");
    }
  }
}

void AdmissionGate::leave(std::chrono::steady_clock::duration held) {
  {
    std::lock_guard lock(mutex_);
    --in_flight_;
    ++completed_;
    const double ms = std::chrono::duration<double, std::milli>(held).count();
    mean_held_ms_ = 0.9 * mean_held_ms_ + 0.1 * ms;
  }
  freed_.notify_one();
}

uint32_t AdmissionGate::retry_after_ms_locked() const {
  // Everyone ahead must get a slot first: (queued + 1) / slots rounds of
  // the mean hold time.
  const double rounds = double(queued_ + 1) / max_in_flight_;
  const double ms = std::clamp(rounds * mean_held_ms_, 10.0, 30000.0);
  return static_cast<uint32_t>(std::lround(ms));
}

uint32_t AdmissionGate::retry_after_ms() const {
  std::lock_guard lock(mutex_);
  return retry_after_ms_locked();
}

AdmissionCounters AdmissionGate::counters() const {
  std::lock_guard lock(mutex_);
  return {in_flight_, queued_, max_in_flight_, max_queued_, completed_, rejected_};
}

}  // namespace pbgi::service
