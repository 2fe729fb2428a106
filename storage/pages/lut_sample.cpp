#include "storage/pages/lut_sample.h"

#include "common/errors.h"

#include <algorithm>
#include <string>

namespace pbgi::storage {

namespace {

// splitmix64 of the arrival index: a fixed, well-mixed priority in [0, 1).
double priority_of(uint64_t index) {
  uint64_t z = index + 0x9E3779B97F4A7C15ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  z ^= z >> 31;
  return double(z >> 11) * 0x1.0p-53;
}

}  // namespace

LutSampleCollector::LutSampleCollector(double fraction, uint64_t min_count)
    : fraction_(fraction), min_count_(min_count), prune_at_(std::max<size_t>(2 * min_count, 1024)) {
  if (!(fraction > 0.0 && fraction <= 1.0)) {
    throw InvalidArgument("LUT sample fraction " + std::to_string(fraction) + ": must be in (0, 1]");
  }
}

void LutSampleCollector::add(std::span<const Surfel> surfels) {
  for (const Surfel& s : surfels) {
    const uint64_t index = offered_++;
    const double p = priority_of(index);
    if (p < fraction_ || p < threshold_) {
      kept_.push_back({p, index, s});
      if (kept_.size() >= prune_at_) prune();
    }
  }
}

// Drops candidates that can no longer be in the sample: those at or above
// the fraction that are not among the min_count lowest priorities.
void LutSampleCollector::prune() {
  if (kept_.size() > min_count_) {
    auto by_priority = [](const Candidate& a, const Candidate& b) { return a.priority < b.priority; };
    std::nth_element(kept_.begin(), kept_.begin() + ptrdiff_t(min_count_), kept_.end(), by_priority);
    threshold_ = kept_[min_count_].priority;  // min_count_ lie below it
    std::erase_if(kept_, [&](const Candidate& c) { return c.priority >= fraction_ && c.priority >= threshold_; });
  }
  // Amortized: prune again only once the kept set has doubled.
  prune_at_ = std::max(prune_at_, 2 * kept_.size());
}

std::vector<Surfel> LutSampleCollector::take() {
  const uint64_t below = uint64_t(std::count_if(kept_.begin(), kept_.end(),
                                                [&](const Candidate& c) { return c.priority < fraction_; }));
  if (below < min_count_) {
    // The min_count lowest priorities (or everything kept).
    auto by_priority = [](const Candidate& a, const Candidate& b) { return a.priority < b.priority; };
    if (kept_.size() > min_count_) {
      std::nth_element(kept_.begin(), kept_.begin() + ptrdiff_t(min_count_), kept_.end(), by_priority);
      kept_.resize(min_count_);
    }
  } else {
    std::erase_if(kept_, [&](const Candidate& c) { return c.priority >= fraction_; });
  }
  std::sort(kept_.begin(), kept_.end(), [](const Candidate& a, const Candidate& b) { return a.index < b.index; });
  std::vector<Surfel> out;
  out.reserve(kept_.size());
  for (const Candidate& c : kept_) out.push_back(c.surfel);
  std::vector<Candidate>().swap(kept_);
  return out;
}

}  // namespace pbgi::storage
