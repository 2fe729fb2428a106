// Wall-clock and process CPU time of a section of code. The bench reports
// both: wall time is what a user waits for; CPU time (all threads of this
// process, user + system) does not grow when other processes compete for
// the cores, so comparisons made on a busy machine stay fair.
//
// Thread-safety: a Stopwatch is used by one thread; it measures the whole
// process, so sections must not overlap (the bench runs one at a time).
#pragma once

#include <chrono>

namespace pbgi::bench {

class Stopwatch {
 public:
  Stopwatch();
  double wall_seconds() const;
  double cpu_seconds() const;

  // CPU time consumed by this process so far (all threads).
  static double process_cpu_seconds();

 private:
  std::chrono::steady_clock::time_point wall0_;
  double cpu0_;
};

}  // namespace pbgi::bench
