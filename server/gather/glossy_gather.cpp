#include "server/gather/glossy_gather.h"

namespace pbgi::gather {

GlossyGather::GlossyGather(const tree::TreeSource& tree, const GatherOptions& options,
                           GatherCache::Impl* shared)
    : lobe_(CubeLayout::get(options.microbuffer_resolution),
            CubeLayout::get(options.effective_glossy_resolution()), options.glossy_importance,
            options.max_solid_angle) {
  const uint32_t fine = options.effective_glossy_resolution();
  if (fine > options.microbuffer_resolution) {
    GatherOptions fine_options = options;
    fine_options.microbuffer_resolution = fine;
    fine_ = std::make_unique<CutWalker>(tree, fine_options, fine_counters_, shared);
  }
}

const Imath::C3f* GlossyGather::begin(const Receiver& r, const Microbuffer& coarse) {
  lobe_.begin(r.normal, r.glossy);
  return lobe_.coarse_gain(coarse);
}

Imath::C3f GlossyGather::refined(const Receiver& r, GatherCounters& counters) {
  if (!fine_ || !lobe_.refined()) return Imath::C3f(0, 0, 0);
  const ClearPinsOnExit unpin{fine_->pins()};
  if (fine_->pins().pinned() == 0) fine_->views().trim();
  fine_->begin_receiver(r.position, r.normal);
  fine_->push_root();
  const uint64_t visited = fine_counters_.nodes_visited;
  fine_->walk_lobe(lobe_);
  counters.glossy_nodes_visited += fine_counters_.nodes_visited - visited;
  counters.pages_fetched += fine_->pins().take_fetches();
  return fine_->resolve(nullptr, lobe_.fine_gain(fine_->buffer())).reflected;
}

}  // namespace pbgi::gather
