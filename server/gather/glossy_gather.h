// The glossy part of a receiver's gather (docs/gather.md, section 14), used
// by PBGI and factorized PBGI alike once the receiver's own microbuffer has
// been walked: its lobe's quadtree (lobe_refinement.h) gives the coarse
// pixels' gains, which the caller's resolve applies, and the refined pixels
// are gathered again here, by a walk into a fine microbuffer.
//
// Thread-safety: none; one per Gatherer. Errors: whatever the TreeSource
// throws, CorruptionError for bad links (as the diffuse walk).
#pragma once

#include "server/gather/cut_walker.h"
#include "server/gather/lobe_refinement.h"

#include <Imath/ImathColor.h>

#include <memory>

namespace pbgi::gather {

class GlossyGather {
 public:
  // `shared`: a GatherCache's page views, or null for private ones.
  GlossyGather(const tree::TreeSource& tree, const GatherOptions& options,
               GatherCache::Impl* shared);

  // Starts receiver r (checked, active lobe): samples its lobe and returns
  // the coarse pixels' gains against `coarse`, the receiver's microbuffer
  // (begun for r), valid until the next begin().
  const Imath::C3f* begin(const Receiver& r, const Microbuffer& coarse);
  // The refined pixels' part of r's glossy radiance (after begin(r)): the
  // fine walk, with pages pinned only during the call. Adds its node visits
  // to counters.glossy_nodes_visited and its page fetches to
  // counters.pages_fetched.
  Imath::C3f refined(const Receiver& r, GatherCounters& counters);

 private:
  LobeRefinement lobe_;
  GatherCounters fine_counters_;  // the fine walker's own
  std::unique_ptr<CutWalker> fine_;  // null: no refinement (fixed buffer)
};

}  // namespace pbgi::gather
