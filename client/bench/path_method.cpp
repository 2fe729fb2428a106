#include "client/bench/path_method.h"

#include "common/errors.h"
#include "server/reference/path_tracer.h"

#include <fmt/format.h>

namespace pbgi::bench {

void PathSweep::validate() const {
  if (max_spp == 0) throw InvalidArgument("bench: path max_spp must be >= 1");
  ReferenceOptions o = path_render_options(16, 16, max_spp, max_depth, seed);
  o.validate();
}

std::vector<uint32_t> spp_ladder(uint32_t max_spp) {
  std::vector<uint32_t> out;
  for (uint64_t spp = 1; spp <= max_spp; spp *= 2) out.push_back(static_cast<uint32_t>(spp));
  if (max_spp > 0 && out.back() != max_spp) out.push_back(max_spp);
  return out;
}

ReferenceOptions path_render_options(uint32_t width, uint32_t height, uint32_t spp,
                                     uint32_t max_depth, uint64_t seed) {
  ReferenceOptions o;
  o.width = width;
  o.height = height;
  o.spp = spp;
  o.pass_spp = spp;  // one pass: no progress callback to serve
  o.max_depth = max_depth;
  o.seed = seed;
  return o;
}

MethodPlan path_plan(const PathSweep& sweep) {
  sweep.validate();
  MethodPlan plan;
  for (uint32_t spp : spp_ladder(sweep.max_spp)) {
    MethodConfig c;
    c.method = "path";
    c.name = fmt::format("path/spp{}", spp);
    c.series = "path";
    c.spp = spp;
    c.params = {{"spp", std::to_string(spp)}, {"max_depth", std::to_string(sweep.max_depth)}};
    c.render = [sweep, spp](const BenchInput& in, const BuiltState*) {
      const ReferenceImage r = render_reference(
          in.rays, in.camera, path_render_options(in.width, in.height, spp, sweep.max_depth, sweep.seed));
      return RenderedAovs{r.beauty, r.direct, r.indirect, {}};
    };
    plan.configs.push_back(std::move(c));
  }
  return plan;
}

}  // namespace pbgi::bench
