// View-tree gather (Wang et al. 2015, "view tree"; docs/gather.md,
// section 9b): the gather of a bounce, whose receivers are the tree's own
// surfels and so come as a hierarchy themselves.
//
// Receivers arrive in the tree's Morton order, so any run of consecutive
// receivers is a compact patch: the receiver hierarchy is the binary split
// of the batch's index range (what the tree's own top-down Morton split
// makes of the same surfels), down to runs of at most kLeafReceivers. Each
// receiver node R gets a frame: the member nearest its centroid, R's
// bounding radius r_R around it, the mean normal and the spread of the
// normals around it.
//
// The walk pairs receiver nodes with sender nodes S, top down:
//  - S is *far* for R when R is small as seen from S: R's view solid angle
//    pi r_R^2 / d^2 <= view_solid_angle (d from R's frame point to S's
//    centre). A far S that passes the cut (small as seen from R) is
//    splatted ONCE into R's far microbuffer (a FarBuffer drawn from R's
//    frame point, far_field.h), and so reaches every surfel below R; a far S
//    that does not pass the cut is opened (its children are paired with R).
//  - otherwise S is *near*. If S is too large for the cut even from R's
//    farthest point, every surfel of R would open it: it is opened here
//    (its children are paired with R), so that its far parts are shared
//    too. Else the pair is refined on the receiver side: R's children
//    start from R's near nodes, with R's far content.
//  - at a receiver leaf (at most kLeafReceivers surfels) the far buffer is
//    resolved once and each surfel walks its near nodes into its own
//    microbuffer (per-surfel visibility and cosine), composited by depth
//    with the shared far content, exactly as factorized PBGI's members are
//    (factorized_gather.h): the receiver node plays the role of FPBGI's
//    cluster, and far content is inherited down the receiver hierarchy
//    instead of being walked again from the root for every cluster.
//
// Visibility: between far senders it is resolved in R's far buffer (a
// depth-sorted A-buffer from R's frame point, off by at most the view angle
// sqrt(view_solid_angle / pi) for R's surfels); near occluders are in each
// surfel's own microbuffer and hide the far content behind them. Normals:
// the far buffer keeps each fragment's direction moments, so each surfel
// convolves the shared content with its own cosine lobe: R's normal cone
// need not be narrow. Culling is conservative over R (every member's
// position and normal).
//
// Thread-safety: none; one per thread. The TreeSource (and a shared
// GatherCache) may be read by several.
#pragma once

#include "server/gather/cut_walker.h"
#include "server/gather/far_field.h"
#include "server/gather/gather.h"

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

namespace pbgi::gather {

class ViewTreeGather {
 public:
  // Receiver nodes of at most this many surfels are not split. Smaller
  // leaves put more senders into shared far buffers (faster) at more
  // parallax (docs/gather.md, section 9b).
  static constexpr uint32_t kLeafReceivers = 4;

  // `view_solid_angle` in (0, pi/4] sr. Throws InvalidArgument for invalid
  // options or view solid angle.
  ViewTreeGather(const tree::TreeSource& tree, const GatherOptions& options, float view_solid_angle,
                 std::shared_ptr<GatherCache> cache = nullptr);
  ~ViewTreeGather();

  // Gathers irradiance and AO at `receivers`, which should be in Morton
  // order (any order is correct; a scattered one is only slower).
  // results[i] belongs to receivers[i]; glossy lobes are ignored. Throws
  // InvalidArgument if the spans differ in size or a receiver has a
  // non-finite position or a zero normal (naming its index), and what the
  // TreeSource throws.
  // Receivers of different air regions (Receiver::region) are gathered
  // run by run, each from its region's subtree.
  void gather(std::span<const Receiver> receivers, std::span<GatherResult> results);

  const GatherCounters& counters() const { return counters_; }

 private:
  // gather() for receivers of one region (`offset`: the first one's index,
  // for errors).
  void gather_region(std::span<const Receiver> receivers, std::span<GatherResult> results, uint32_t region,
                     size_t offset);
  // Receiver node: receivers_[first, first + count) at depth `level`,
  // starting from the sender nodes `from` (level 0: the root).
  void gather_node(uint32_t first, uint32_t count, uint32_t level, std::span<const StackEntry> from,
                   std::span<GatherResult> results);
  ClusterFrame frame_of(uint32_t first, uint32_t count) const;

  GatherCounters counters_;
  std::shared_ptr<GatherCache> cache_;  // kept alive while views point into it
  CutWalker walker_;
  float epsilon_;                                 // sqrt(view_solid_angle / pi)
  std::vector<Receiver> receivers_;               // checked copies
  std::vector<std::unique_ptr<FarBuffer>> far_;   // one per receiver level
  std::vector<std::vector<StackEntry>> near_;     // one per receiver level
};

}  // namespace pbgi::gather
