// Exact nearest-centre search over a table of up to 65536 centres in a few
// tens of dimensions: the LUT search of quantized SH payloads and the
// assignment step of k-means.
//
// Method: the caller gives centres and queries in coordinates ordered by
// decreasing variance (a PcaBasis rotation, storage/codecs/pca_basis.h).
// Centres are organized in a kd-tree over the leading kBoxDims coordinates
// (median splits on the widest one, leaves of at most kLeafSize centres,
// each node with its bounding box over those coordinates). A query visits
// the nearer child first and skips every node whose box is farther than the
// best distance found so far; since the leading coordinates carry most of
// the variance, the box bound is tight. Each candidate's squared distance is
// summed in blocks of 8 coordinates (8 independent lanes: vectorizable
// without reassociating float sums) and abandoned as soon as the partial
// sum exceeds the best distance. A hint (e.g. the previous answer of a
// coherent stream of queries) seeds the best distance.
//
// Exactness: the result is the centre of minimal squared distance, ties
// broken towards the lower index, with distances computed exactly as
// brute_force() computes them (same function, same order of operations).
// Box bounds are shrunk by a margin larger than their float rounding, so a
// skipped centre is always strictly farther than the best.
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
  static constexpr size_t kBoxDims = 8;   // leading coordinates bounded per kd node
  static constexpr size_t kLeafSize = 8;  // centres per kd leaf

  // `centres`: `count` vectors of `dims` floats, contiguous. Throws
  // InvalidArgument for no centres, dims 0 or > 256, or a size mismatch.
  NearestCentreTable(std::span<const float> centres, size_t dims);

  size_t dims() const { return dims_; }
  size_t size() const { return count_; }

  // The nearest centre to q (dims floats). `hint`: a centre likely to be
  // near; it only speeds the search up.
  NearestResult search(const float* q, uint32_t hint = kNoHint) const;
  // The same answer by exhaustive search, for tests and tiny tables.
  NearestResult brute_force(const float* q) const;
  // Centre i's coordinates (constructor order), zero-padded to a multiple of 8.
  const float* centre(uint32_t i) const { return &sorted_[size_t(rank_[i]) * stride_]; }

  // Squared distance of two vectors padded to `stride` (a multiple of 8),
  // abandoned (returning a value > bound) once a block's partial sum
  // exceeds `bound`.
  static float distance2_bounded(const float* a, const float* b, size_t stride, float bound);

 private:
  struct KdNode {
    float lo[kBoxDims], hi[kBoxDims];
    uint32_t begin = 0, end = 0;   // centres [begin, end) in kd order
    uint32_t child = 0;            // 0: leaf; else children at child, child + 1
  };
  void build(uint32_t node, uint32_t begin, uint32_t end, std::vector<uint32_t>& order,
             std::span<const float> centres);
  float box_bound(const KdNode& n, const float* q) const;
  void pad_query(const float* q, float* out) const;

  size_t dims_ = 0;
  size_t stride_ = 0;            // dims rounded up to a multiple of 8
  size_t box_dims_ = 0;          // min(dims, kBoxDims)
  size_t count_ = 0;
  std::vector<float> sorted_;    // centres in kd order, zero-padded
  std::vector<uint32_t> index_;  // kd position -> constructor index
  std::vector<uint32_t> rank_;   // constructor index -> kd position
  std::vector<KdNode> nodes_;    // nodes_[0] is the root
};

}  // namespace pbgi::storage
