// The glossy part of a receiver's gather (docs/gather.md, section 14), used
// by PBGI and factorized PBGI alike once the receiver's own microbuffer has
// been walked: resolve() resolves that buffer keeping each pixel's light,
// builds the lobe's quadtree (lobe_refinement.h) from the lobe and that
// light, and convolves the unrefined pixels with the lobe; refined() gathers
// the refined pixels again, by a walk into a fine microbuffer.
//
// Thread-safety: none; one per Gatherer. Errors: whatever the TreeSource
// throws, CorruptionError for bad links (as the diffuse walk).
#pragma once

#include "server/gather/cut_walker.h"
#include "server/gather/lobe_refinement.h"

#include <Imath/ImathColor.h>

#include <memory>

namespace pbgi {
class VolumePoints;
}

namespace pbgi::gather {

class GlossyGather {
 public:
  // `shared`: a GatherCache's page views, or null for private ones.
  GlossyGather(const tree::TreeSource& tree, const GatherOptions& options,
               GatherCache::Impl* shared);

  // Resolves receiver r's coarse microbuffer (`walker`'s, walked for r,
  // with a cluster's far content if any) as CutWalker::resolve does, and
  // starts r's lobe (r checked, lobe active): Resolved::reflected holds
  // the unrefined pixels' part of r's glossy radiance.
  Resolved resolve(const Receiver& r, CutWalker& walker, const FarBuffer* far);
  // The refined pixels' part of r's glossy radiance (after resolve(r)):
  // the fine walk, with the fog's points if any (volume_fragments.h), with
  // pages pinned only during the call. Adds its node visits to
  // counters.glossy_nodes_visited and its page fetches to
  // counters.pages_fetched.
  // `region`: the receiver's air region (CutWalker::locate).
  Imath::C3f refined(const Receiver& r, uint32_t region, GatherCounters& counters, const VolumePoints* fog);

 private:
  LobeRefinement lobe_;
  std::vector<PixelLight> light_;  // the coarse buffer's, per receiver
  GatherCounters fine_counters_;  // the fine walker's own
  std::unique_ptr<CutWalker> fine_;  // null: no refinement (fixed buffer)
};

}  // namespace pbgi::gather
