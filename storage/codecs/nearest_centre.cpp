#include "storage/codecs/nearest_centre.h"

#include "storage/format/errors.h"

#include <algorithm>
#include <numeric>
#include <string>

namespace pbgi::storage {

namespace {
constexpr size_t kLanes = 8;
constexpr size_t kMaxStride = 256;
}  // namespace

NearestCentreTable::NearestCentreTable(std::span<const float> centres, size_t dims) : dims_(dims) {
  if (dims == 0 || centres.empty() || centres.size() % dims != 0) {
    throw InvalidArgument("NearestCentreTable: " + std::to_string(centres.size()) +
                          " floats is not a non-empty set of " + std::to_string(dims) + "-vectors");
  }
  stride_ = (dims + kLanes - 1) / kLanes * kLanes;
  if (stride_ > kMaxStride) {
    throw InvalidArgument("NearestCentreTable: " + std::to_string(dims) + " dimensions (at most " +
                          std::to_string(kMaxStride) + ")");
  }
  count_ = centres.size() / dims;
  if (count_ >= kNoHint) throw InvalidArgument("NearestCentreTable: too many centres");
  index_.resize(count_);
  std::iota(index_.begin(), index_.end(), 0u);
  std::stable_sort(index_.begin(), index_.end(),
                   [&](uint32_t a, uint32_t b) { return centres[a * dims] < centres[b * dims]; });
  sorted_.assign(count_ * stride_, 0.f);
  key_.resize(count_);
  rank_.resize(count_);
  for (size_t s = 0; s < count_; ++s) {
    const float* c = &centres[size_t(index_[s]) * dims];
    std::copy(c, c + dims, &sorted_[s * stride_]);
    key_[s] = c[0];
    rank_[index_[s]] = uint32_t(s);
  }
}

float NearestCentreTable::distance2_bounded(const float* a, const float* b, size_t stride, float bound) {
  float total = 0.f;
  for (size_t base = 0; base < stride; base += kLanes) {
    float lane[kLanes];
    for (size_t j = 0; j < kLanes; ++j) {
      const float d = a[base + j] - b[base + j];
      lane[j] = d * d;
    }
    // Fixed pairwise order: the same float result wherever it is inlined.
    const float block = ((lane[0] + lane[1]) + (lane[2] + lane[3])) + ((lane[4] + lane[5]) + (lane[6] + lane[7]));
    total += block;
    if (total > bound) return total;
  }
  return total;
}

void NearestCentreTable::pad_query(const float* q, float* out) const {
  std::copy(q, q + dims_, out);
  std::fill(out + dims_, out + stride_, 0.f);
}

NearestResult NearestCentreTable::search(const float* q_in, uint32_t hint) const {
  alignas(32) float q[kMaxStride];
  pad_query(q_in, q);
  NearestResult best;
  uint32_t best_sorted = 0xffffffffu;
  auto consider = [&](size_t s) {
    const float d = distance2_bounded(q, &sorted_[s * stride_], stride_, best.distance2);
    if (d < best.distance2 || (d == best.distance2 && index_[s] < best.index)) {
      best.distance2 = d;
      best.index = index_[s];
      best_sorted = uint32_t(s);
    }
  };
  if (hint < count_) consider(rank_[hint]);

  const float q0 = q[0];
  const size_t start = size_t(std::lower_bound(key_.begin(), key_.end(), q0) - key_.begin());
  ptrdiff_t lo = ptrdiff_t(start) - 1;
  size_t hi = start;
  constexpr float kInf = std::numeric_limits<float>::infinity();
  while (lo >= 0 || hi < count_) {
    const float dlo = lo >= 0 ? q0 - key_[size_t(lo)] : kInf;
    const float dhi = hi < count_ ? key_[hi] - q0 : kInf;
    const bool take_lo = dlo <= dhi;
    const float gap = take_lo ? dlo : dhi;
    // gap^2 is the first term of every remaining candidate's distance sum
    // (sums of non-negative floats never decrease), so a gap^2 above the
    // best excludes every centre further out on both sides.
    if (gap * gap > best.distance2) break;
    const size_t s = take_lo ? size_t(lo--) : hi++;
    if (s != best_sorted) consider(s);
  }
  return best;
}

NearestResult NearestCentreTable::brute_force(const float* q_in) const {
  alignas(32) float q[kMaxStride];
  pad_query(q_in, q);
  NearestResult best;
  constexpr float kInf = std::numeric_limits<float>::infinity();
  for (uint32_t i = 0; i < count_; ++i) {
    const float d = distance2_bounded(q, &sorted_[size_t(rank_[i]) * stride_], stride_, kInf);
    if (d < best.distance2) {  // i increases: ties keep the lower index
      best.distance2 = d;
      best.index = i;
    }
  }
  return best;
}

}  // namespace pbgi::storage
