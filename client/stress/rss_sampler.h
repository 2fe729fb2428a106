// The resident set size of a process over time, read from
// /proc/<pid>/status (VmRSS), for soak runs: a daemon whose RSS keeps
// growing under a steady load leaks.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <filesystem>
#include <mutex>
#include <thread>
#include <vector>

namespace pbgi::stress {

// VmRSS of `pid` in bytes. Throws NotFound if the process does not exist,
// IoError if its status cannot be read or has no VmRSS line (a zombie).
uint64_t read_rss_bytes(pid_t pid);

struct RssSample {
  double seconds = 0;       // since the sampler started
  uint64_t rss_bytes = 0;
};

// Samples a process's RSS every `interval` on its own thread from
// construction until stop() (or destruction). A process that exits ends
// the sampling quietly (its last sample stays).
// Thread-safety: samples()/peak_bytes() may be called while sampling.
class RssSampler {
 public:
  RssSampler(pid_t pid, std::chrono::milliseconds interval);
  ~RssSampler();
  RssSampler(const RssSampler&) = delete;
  RssSampler& operator=(const RssSampler&) = delete;

  void stop();
  std::vector<RssSample> samples() const;
  uint64_t peak_bytes() const;

 private:
  void run();

  const pid_t pid_;
  const std::chrono::milliseconds interval_;
  const std::chrono::steady_clock::time_point start_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  bool stopping_ = false;
  std::vector<RssSample> samples_;
  std::thread thread_;
};

// Writes "seconds,rss_mib" rows (with a header) to `path`. Throws IoError.
void write_rss_csv(const std::vector<RssSample>& samples, const std::filesystem::path& path);

// Growth of the RSS over a run that ignores warm-up: the mean of the last
// quarter of the samples minus the mean of the second quarter (bytes; may
// be negative). 0 with fewer than 4 samples.
double rss_growth_bytes(const std::vector<RssSample>& samples);

}  // namespace pbgi::stress
