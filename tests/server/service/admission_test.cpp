// The admission gate: slots, a bounded queue, refusal with a retry hint,
// and waiters that give up on their deadline or cancellation.
#include "server/service/admission.h"

#include <gtest/gtest.h>

#include <atomic>
#include <future>
#include <optional>
#include <thread>

namespace pbgi::service {
namespace {

using namespace std::chrono_literals;
using SystemClock = std::chrono::system_clock;

SystemClock::time_point in(std::chrono::milliseconds ms) { return SystemClock::now() + ms; }

TEST(AdmissionGate, QueuesThenRefusesWithARetryHint) {
  AdmissionGate gate(1, 1);
  std::optional<AdmissionGate::Ticket> first(gate.enter(in(10s)));
  EXPECT_EQ(gate.counters().in_flight, 1u);

  // The second waits in the queue...
  std::atomic<bool> admitted{false};
  std::thread second([&] {
    AdmissionGate::Ticket t = gate.enter(in(10s));
    admitted = true;
  });
  while (gate.counters().queued == 0) std::this_thread::sleep_for(1ms);
  EXPECT_FALSE(admitted);

  // ...the third finds the queue full and is refused at once.
  try {
    gate.enter(in(10s));
    FAIL() << "admitted past the queue";
  } catch (const Overloaded& e) {
    EXPECT_GE(e.retry_after_ms, 10u);
    EXPECT_LE(e.retry_after_ms, 30000u);
    EXPECT_NE(std::string(e.what()).find("overloaded"), std::string::npos) << e.what();
  }
  EXPECT_EQ(gate.counters().rejected, 1u);

  // Freeing the slot lets the waiter in.
  first.reset();
  second.join();
  EXPECT_TRUE(admitted);
  const AdmissionCounters c = gate.counters();
  EXPECT_EQ(c.in_flight, 0u);
  EXPECT_EQ(c.queued, 0u);
  EXPECT_EQ(c.completed, 2u);
}

TEST(AdmissionGate, WaitersGiveUpOnDeadlineAndCancellation) {
  AdmissionGate gate(1, 4);
  AdmissionGate::Ticket held = gate.enter(in(10s));

  const auto start = std::chrono::steady_clock::now();
  EXPECT_THROW(gate.enter(in(30ms)), Cancelled);
  const auto waited = std::chrono::steady_clock::now() - start;
  EXPECT_GE(waited, 25ms);
  EXPECT_LT(waited, 500ms) << "the deadline is noticed promptly";

  std::atomic<bool> cancel{false};
  auto waiter = std::async(std::launch::async, [&] {
    try {
      gate.enter(in(10s), [&] { return cancel.load(); });
      return false;
    } catch (const Cancelled&) {
      return true;
    }
  });
  std::this_thread::sleep_for(20ms);
  cancel = true;
  ASSERT_EQ(waiter.wait_for(1s), std::future_status::ready);
  EXPECT_TRUE(waiter.get());
  EXPECT_EQ(gate.counters().queued, 0u) << "a waiter that gave up leaves the queue";
  EXPECT_EQ(gate.counters().in_flight, 1u);
}

TEST(AdmissionGate, HintGrowsWithTheQueueAndTheHoldTime) {
  AdmissionGate gate(1, 8);
  // Slots held ~20 ms each teach the gate its service time.
  for (int i = 0; i < 20; ++i) {
    AdmissionGate::Ticket t = gate.enter(in(1s));
    std::this_thread::sleep_for(20ms);
  }
  const uint32_t idle_hint = gate.retry_after_ms();
  EXPECT_GE(idle_hint, 10u);
  AdmissionGate::Ticket held = gate.enter(in(1s));
  std::vector<std::thread> waiters;
  for (int i = 0; i < 3; ++i) {
    waiters.emplace_back([&] {
      try {
        gate.enter(in(200ms));
      } catch (const Cancelled&) {
      }
    });
  }
  while (gate.counters().queued < 3) std::this_thread::sleep_for(1ms);
  EXPECT_GT(gate.retry_after_ms(), idle_hint) << "more waiting ahead: a longer hint";
  for (auto& t : waiters) t.join();
}

}  // namespace
}  // namespace pbgi::service
