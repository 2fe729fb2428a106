#include "client/stress/rss_sampler.h"

#include "common/errors.h"

#include <fmt/format.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>

namespace pbgi::stress {

uint64_t read_rss_bytes(pid_t pid) {
  const std::string path = fmt::format("/proc/{}/status", pid);
  std::ifstream in(path);
  if (!in) {
    if (errno == ENOENT) throw NotFound(fmt::format("process {} does not exist ({})", pid, path));
    throw IoError(fmt::format("cannot read {}: {}", path, std::strerror(errno)));
  }
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("VmRSS:", 0) != 0) continue;
    std::istringstream fields(line.substr(6));
    uint64_t kib = 0;
    std::string unit;
    if (!(fields >> kib >> unit) || unit != "kB") {
      throw IoError(fmt::format("{}: unexpected VmRSS line '{}'", path, line));
    }
    return kib * 1024;
  }
  throw IoError(fmt::format("{}: no VmRSS line (process {} exited?)", path, pid));
}

RssSampler::RssSampler(pid_t pid, std::chrono::milliseconds interval)
    : pid_(pid), interval_(interval), start_(std::chrono::steady_clock::now()) {
  samples_.push_back({0.0, read_rss_bytes(pid)});  // fails early for a wrong pid
  thread_ = std::thread([this] { run(); });
}

RssSampler::~RssSampler() { stop(); }

void RssSampler::stop() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void RssSampler::run() {
  std::unique_lock lock(mutex_);
  for (;;) {
    if (wake_.wait_for(lock, interval_, [this] { return stopping_; })) return;
    lock.unlock();
    uint64_t rss = 0;
    try {
      rss = read_rss_bytes(pid_);
    } catch (const Error&) {
      return;  // the process is gone: its curve ends here
    }
    const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    lock.lock();
    samples_.push_back({t, rss});
  }
}

std::vector<RssSample> RssSampler::samples() const {
  std::lock_guard lock(mutex_);
  return samples_;
}

uint64_t RssSampler::peak_bytes() const {
  std::lock_guard lock(mutex_);
  uint64_t peak = 0;
  for (const RssSample& s : samples_) peak = std::max(peak, s.rss_bytes);
  return peak;
}

void write_rss_csv(const std::vector<RssSample>& samples, const std::filesystem::path& path) {
  std::ofstream out(path);
  if (!out) throw IoError(fmt::format("cannot write {}: {}", path.string(), std::strerror(errno)));
  out << "seconds,rss_mib\n";
  for (const RssSample& s : samples) {
    out << fmt::format("{:.3f},{:.3f}\n", s.seconds, s.rss_bytes / (1024.0 * 1024.0));
  }
  if (!out.flush()) throw IoError(fmt::format("error writing {}", path.string()));
}

double rss_growth_bytes(const std::vector<RssSample>& samples) {
  const size_t n = samples.size();
  if (n < 4) return 0;
  auto mean = [&](size_t begin, size_t end) {
    double sum = 0;
    for (size_t i = begin; i < end; ++i) sum += double(samples[i].rss_bytes);
    return sum / double(end - begin);
  };
  return mean(3 * n / 4, n) - mean(n / 4, n / 2);
}

}  // namespace pbgi::stress
