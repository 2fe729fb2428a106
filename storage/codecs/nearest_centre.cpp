#include "storage/codecs/nearest_centre.h"

#include "common/errors.h"

#include <algorithm>
#include <numeric>
#include <string>

namespace pbgi::storage {

namespace {
constexpr size_t kLanes = 8;
constexpr size_t kMaxStride = 256;
// Box bounds are summed in a different order than distances; shrinking them
// by far more than that rounding (< 50 float ulps) keeps pruning exact.
constexpr float kBoundMargin = 1.f - 1e-5f;
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
  box_dims_ = std::min(dims, kBoxDims);
  count_ = centres.size() / dims;
  if (count_ >= kNoHint) throw InvalidArgument("NearestCentreTable: too many centres");

  std::vector<uint32_t> order(count_);
  std::iota(order.begin(), order.end(), 0u);
  nodes_.reserve(2 * (count_ / kLeafSize + 1));
  nodes_.emplace_back();
  build(0, 0, uint32_t(count_), order, centres);

  index_ = order;
  sorted_.assign(count_ * stride_, 0.f);
  rank_.resize(count_);
  for (size_t s = 0; s < count_; ++s) {
    const float* c = &centres[size_t(index_[s]) * dims];
    std::copy(c, c + dims, &sorted_[s * stride_]);
    rank_[index_[s]] = uint32_t(s);
  }
}

void NearestCentreTable::build(uint32_t node, uint32_t begin, uint32_t end, std::vector<uint32_t>& order,
                               std::span<const float> centres) {
  KdNode n;
  n.begin = begin;
  n.end = end;
  int axis = 0;
  float widest = -1.f;
  for (size_t k = 0; k < kBoxDims; ++k) {
    n.lo[k] = 0.f;
    n.hi[k] = 0.f;
    if (k >= box_dims_) continue;
    float lo = centres[size_t(order[begin]) * dims_ + k], hi = lo;
    for (uint32_t i = begin; i < end; ++i) {
      const float v = centres[size_t(order[i]) * dims_ + k];
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
    n.lo[k] = lo;
    n.hi[k] = hi;
    if (hi - lo > widest) {
      widest = hi - lo;
      axis = int(k);
    }
  }
  if (end - begin <= kLeafSize || widest <= 0.f) {
    nodes_[node] = n;
    return;
  }
  const uint32_t mid = begin + (end - begin) / 2;
  std::nth_element(order.begin() + begin, order.begin() + mid, order.begin() + end, [&](uint32_t a, uint32_t b) {
    const float va = centres[size_t(a) * dims_ + axis], vb = centres[size_t(b) * dims_ + axis];
    return va < vb || (va == vb && a < b);
  });
  n.child = uint32_t(nodes_.size());
  nodes_[node] = n;
  nodes_.emplace_back();
  nodes_.emplace_back();
  build(n.child, begin, mid, order, centres);
  build(n.child + 1, mid, end, order, centres);
}

float NearestCentreTable::box_bound(const KdNode& n, const float* q) const {
  float s = 0.f;
  for (size_t k = 0; k < kBoxDims; ++k) {
    const float g = std::max({0.f, n.lo[k] - q[k], q[k] - n.hi[k]});
    s += g * g;
  }
  return s * kBoundMargin;
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
  auto consider = [&](size_t s) {
    const float d = distance2_bounded(q, &sorted_[s * stride_], stride_, best.distance2);
    if (d < best.distance2 || (d == best.distance2 && index_[s] < best.index)) {
      best.distance2 = d;
      best.index = index_[s];
    }
  };
  if (hint < count_) consider(rank_[hint]);

  // Depth-first, nearer child first; a node is entered only if its box
  // could hold a centre at most as far as the best (ties included).
  struct Pending {
    uint32_t node;
    float bound;
  };
  Pending stack[64];
  int top = 0;
  stack[top++] = {0, box_bound(nodes_[0], q)};
  while (top > 0) {
    const Pending p = stack[--top];
    if (p.bound > best.distance2) continue;
    const KdNode& n = nodes_[p.node];
    if (n.child == 0) {
      for (uint32_t s = n.begin; s < n.end; ++s) consider(s);
      continue;
    }
    const float b0 = box_bound(nodes_[n.child], q), b1 = box_bound(nodes_[n.child + 1], q);
    // Push the farther child first so the nearer one is searched first.
    if (b0 <= b1) {
      stack[top++] = {n.child + 1, b1};
      stack[top++] = {n.child, b0};
    } else {
      stack[top++] = {n.child, b0};
      stack[top++] = {n.child + 1, b1};
    }
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
