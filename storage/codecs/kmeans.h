// k-means clustering (Lloyd 1982) with k-means++ seeding (Arthur &
// Vassilvitskii 2007): learns the LUT of quantized SH payloads from the node
// data vectors of a sample tree (Buchholz & Boubekeur 2012, section 3.1).
//
// 1. The points are rotated into their PCA basis (distances unchanged), so
//    every nearest-centre query can use NearestCentreTable's early exits.
// 2. Seeding: k-means++ picks each new centre with probability proportional
//    to the squared distance to the nearest centre chosen so far. Done
//    exactly but pruned: points are grouped into blocks of ~64 with a
//    bounding box over the leading coordinates, and a new centre only
//    visits blocks whose box is nearer than the block's largest current
//    distance; the cost falls as the centres fill the space.
// 3. Lloyd iterations: assign every point to its nearest centre (exact,
//    warm-started at its previous centre), re-seed empty clusters at the
//    points farthest from their centres, move each centre to its cluster's
//    mean. The objective (sum of squared distances) never increases: a
//    centre only moves if that lowers its cluster's cost as computed in
//    float, assignments only change to a nearer centre, and a re-seeded
//    point's cost drops to 0.
//
// Deterministic for a given seed (any number of threads). Thread-safety:
// pure function; uses the TBB thread pool.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace pbgi::storage {

struct KMeansOptions {
  uint32_t clusters = 1024;       // requested number of centres (>= 1)
  uint32_t max_iterations = 15;   // Lloyd iterations after seeding (paper: 10-20)
  // Stop early once an iteration lowers the objective by less than this
  // fraction of its value.
  double min_improvement = 1e-4;
  uint64_t seed = 1;
  // Optional starting centres (count x dims floats) instead of the k-means++
  // seeding, e.g. a previous LUT; `clusters` is then ignored.
  std::vector<float> initial_centres;

  void validate() const;  // throws InvalidArgument naming the field
};

struct KMeansResult {
  // min(clusters, number of distinct points) centres, dims floats each, in
  // the input coordinates.
  std::vector<float> centres;
  size_t dims = 0;
  std::vector<uint32_t> assignment;  // per point: index of its centre
  // Sum of squared distances of the points to their centres: [0] after
  // seeding, then after each iteration. Non-increasing.
  std::vector<double> objective;
  uint32_t iterations = 0;
  uint32_t reseeded = 0;             // empty clusters re-seeded in total
  double seeding_seconds = 0, lloyd_seconds = 0;

  size_t size() const { return dims ? centres.size() / dims : 0; }
};

// Clusters `points` (count x dims floats, contiguous; all finite).
// Throws InvalidArgument for invalid options, no points, a size mismatch,
// or a non-finite coordinate.
KMeansResult kmeans(std::span<const float> points, size_t dims, const KMeansOptions& options);

}  // namespace pbgi::storage
