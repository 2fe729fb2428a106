// Exact nearest-centre search over a table of up to a few 10^4 centres in
// a few tens of dimensions: the LUT search of quantized SH payloads and the
// assignment step of k-means.
//
// Method ("PCA-ordered table with early exit"): the caller gives centres and
// queries in coordinates ordered by decreasing variance (a PcaBasis
// rotation). Centres are sorted by their first coordinate. A query starts at
// its own first coordinate (binary search) and walks outward on both sides,
// always taking the side whose first-coordinate gap is smaller; once that
// gap squared exceeds the best distance found, no further centre can be
// nearer and the walk stops. Each candidate's squared distance is summed in
// blocks of 8 coordinates (8 independent lanes: vectorizable without
// reassociating float sums) and abandoned as soon as the partial sum exceeds
// the best distance; high-variance coordinates come first, so most
// candidates are dropped after one block.
//
// Exactness: the result is the centre of minimal squared distance, ties
// broken towards the lower index, with distances computed exactly as
// brute_force() computes them (same function, same order of operations). The
// pruning tests are conservative: a skipped centre's distance is strictly
// greater than the best.
//
// Thread-safety: immutable after construction; search() is const and may
// run concurrently.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <span>
#include <vector>

namespace pbgi::storage {

struct NearestResult {
  uint32_t index = 0;   // index of the centre in the constructor's order
  float distance2 = std::numeric_limits<float>::infinity();  // squared L2
};

class NearestCentreTable {
 public:
  static constexpr uint32_t kNoHint = 0xffffffffu;

  // `centres`: `count` vectors of `dims` floats, contiguous. Throws
  // InvalidArgument for no centres, dims 0, or a size mismatch.
  NearestCentreTable(std::span<const float> centres, size_t dims);

  size_t dims() const { return dims_; }
  size_t size() const { return count_; }

  // The nearest centre to q (dims floats). `hint`: a centre likely to be
  // near (e.g. last iteration's assignment); it only speeds the search up.
  NearestResult search(const float* q, uint32_t hint = kNoHint) const;
  // The same answer by exhaustive search, for tests and tiny tables.
  NearestResult brute_force(const float* q) const;
  // Centre i's coordinates (constructor order).
  const float* centre(uint32_t i) const { return &sorted_[size_t(rank_[i]) * stride_]; }

  // Squared distance of two padded vectors, abandoned (returning a value
  // > bound) once a block's partial sum exceeds `bound`.
  static float distance2_bounded(const float* a, const float* b, size_t stride, float bound);

 private:
  void pad_query(const float* q, float* out) const;

  size_t dims_ = 0;
  size_t stride_ = 0;            // dims rounded up to a multiple of 8
  size_t count_ = 0;
  std::vector<float> sorted_;    // centres sorted by coordinate 0, zero-padded
  std::vector<float> key_;       // coordinate 0 of sorted_[i]
  std::vector<uint32_t> index_;  // sorted position -> constructor index
  std::vector<uint32_t> rank_;   // constructor index -> sorted position
};

}  // namespace pbgi::storage
