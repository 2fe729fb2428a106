// Variational clustering of a tile's receivers (factorized PBGI, Wang et
// al. 2013, section 3.1): k-means with the Sobolev-like metric
//   D(x, c) = |p_x - p_c|^2 + alpha |n_x - n_c|^2,
// alpha = (diagonal of the tile's receiver bounding box)^2, which makes the
// normal term as strong as the tile's spatial extent (the paper uses the
// diagonal; squaring keeps D in units of length^2, so clusters do not
// depend on the scene's scale). Centers start at receivers spread evenly
// over the batch (deterministic), positions and normals are averaged
// (normals renormalized) for a fixed number of iterations, and each
// cluster's *active* receiver is the member nearest its center.
//
// Positions are taken relative to the first receiver, so a scene far from
// the origin clusters exactly like the same scene at the origin.
//
// Thread-safety: none; one per Gatherer. No allocation once its buffers
// have grown to the tile size.
#pragma once

#include "server/gather/cut_walker.h"
#include "server/gather/gather.h"

#include <cstdint>
#include <span>
#include <vector>

namespace pbgi::gather {

struct ReceiverCluster {
  uint32_t active = 0;           // index in the batch
  uint32_t first = 0, count = 0; // range in ReceiverClusters::members()
  ClusterFrame frame;
};

class ReceiverClusters {
 public:
  static constexpr uint32_t kDefaultIterations = 4;

  // Clusters `receivers` (finite positions, unit normals) into at most k
  // non-empty clusters.
  void build(std::span<const Receiver> receivers, uint32_t k,
             uint32_t iterations = kDefaultIterations);

  const std::vector<ReceiverCluster>& clusters() const { return clusters_; }
  // Receiver indices grouped by cluster.
  const std::vector<uint32_t>& members() const { return members_; }

 private:
  std::vector<Imath::V3f> pos_, center_p_, center_n_, sum_p_, sum_n_;
  std::vector<uint32_t> assign_, size_, offset_;
  std::vector<ReceiverCluster> clusters_;
  std::vector<uint32_t> members_;
};

}  // namespace pbgi::gather
