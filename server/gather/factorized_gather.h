// Factorized PBGI (Wang, Meng, Boubekeur, EGSR 2013) over a CutWalker: a
// batch of receivers (an image tile) is clustered (receiver_clusters.h);
// per cluster
//  1. the coarse cut of the active receiver is walked once, culling only
//     what no member can see; far nodes (gamma = cluster radius / distance
//     <= epsilon) are splatted into the cluster's shared FarBuffer, near
//     nodes stop the walk;
//  2. the FarBuffer is resolved once;
//  3. each member walks the PBGI cut from the near nodes only, into its
//     own (sparse) microbuffer, which is composited by depth with the far
//     content and convolved with the member's cosine lobe; a glossy member
//     also with its GGX lobe (the coarse pixels, far content included),
//     and its refined pixels are gathered on their own (glossy_gather.h).
// The batch's pages stay pinned from one cluster to the next (up to a
// bound, factorized_gather.cpp), so that neighbouring clusters fetch the
// pages they share once.
//
// Thread-safety: none; one per Gatherer.
#pragma once

#include "server/gather/cut_walker.h"
#include "server/gather/far_field.h"
#include "server/gather/glossy_gather.h"
#include "server/gather/receiver_clusters.h"

#include <cstdint>
#include <span>
#include <utility>
#include <vector>

namespace pbgi {
class VolumePoints;  // server/scene/volume_points.h
}  // namespace pbgi

namespace pbgi::gather {

class FactorizedGather {
 public:
  explicit FactorizedGather(CutWalker& walker);

  // `receivers` are validated (finite, unit normals); results in order.
  // `glossy` serves the members with an active lobe (null: none has one);
  // `fog`: the scene's volume points (volume_fragments.h), added to each
  // receiver's microbuffer, or null.
  void gather(std::span<const Receiver> receivers, std::span<GatherResult> results,
              GatherCounters& counters, GlossyGather* glossy = nullptr, const VolumePoints* fog = nullptr);

 private:
  CutWalker& walker_;
  ReceiverClusters clusters_;
  FarBuffer far_;
  std::vector<StackEntry> near_;
  // The clusters in the order they are gathered: along a Morton curve of
  // their active receivers' positions, so that consecutive clusters walk
  // mostly the same near pages, which stay pinned from one to the next
  // (the 2M city's render at 64 x 48 fetched 7.5% fewer pages than in the
  // seeds' scan order). Each cluster's results do not depend on the order.
  void visit_in_space_order(const std::vector<ReceiverCluster>& clusters);
  std::vector<uint32_t> order_;
  std::vector<std::pair<uint64_t, uint32_t>> keyed_;  // (Morton code, cluster)
};

// Clusters for a batch of n receivers: k per 1024 receivers, at least 1.
uint32_t cluster_count(uint32_t k_per_1024, size_t n);

}  // namespace pbgi::gather
