#include "server/gather/glossy_gather.h"

#include "server/gather/volume_fragments.h"

namespace pbgi::gather {

GlossyGather::GlossyGather(const tree::TreeSource& tree, const GatherOptions& options,
                           GatherCache::Impl* shared)
    : lobe_(CubeLayout::get(options.microbuffer_resolution),
            CubeLayout::get(options.effective_glossy_resolution()), options.glossy_importance,
            options.glossy_radiance_weight, options.max_solid_angle) {
  const uint32_t fine = options.effective_glossy_resolution();
  if (fine > options.microbuffer_resolution) {
    GatherOptions fine_options = options;
    fine_options.microbuffer_resolution = fine;
    fine_ = std::make_unique<CutWalker>(tree, fine_options, fine_counters_, shared);
  }
}

Resolved GlossyGather::resolve(const Receiver& r, CutWalker& walker, const FarBuffer* far) {
  Resolved out = walker.resolve(far, nullptr, &light_);
  const Microbuffer& coarse = walker.buffer();
  lobe_.begin(r.normal, r.glossy, light_, coarse);
  const Imath::C3f* gain = lobe_.coarse_gain(coarse);
  double gr = 0, gg = 0, gb = 0;
  for (const PixelLight& p : light_) {
    gr += double(gain[p.pixel].x * p.light.x);
    gg += double(gain[p.pixel].y * p.light.y);
    gb += double(gain[p.pixel].z * p.light.z);
  }
  out.reflected = Imath::C3f(float(gr), float(gg), float(gb));
  return out;
}

Imath::C3f GlossyGather::refined(const Receiver& r, uint32_t region, GatherCounters& counters,
                                 const VolumePoints* fog) {
  if (!fine_ || !lobe_.refined()) return Imath::C3f(0, 0, 0);
  const ClearPinsOnExit unpin{fine_->pins()};
  if (fine_->pins().pinned() == 0) fine_->views().trim();
  fine_->begin_receiver(r.position, r.normal);
  fine_->push_root(region);
  const uint64_t visited = fine_counters_.nodes_visited;
  fine_->walk_lobe(lobe_);
  // The fog in front of the refined pixels, as in the coarse buffer.
  if (fog) add_volume_fragments(*fog, r.position, fine_->buffer());
  counters.glossy_nodes_visited += fine_counters_.nodes_visited - visited;
  counters.pages_fetched += fine_->pins().take_fetches();
  return fine_->resolve(nullptr, lobe_.fine_gain(fine_->buffer())).reflected;
}

}  // namespace pbgi::gather
