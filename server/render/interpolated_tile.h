// The interpolating tile renderer (RenderOptions::interpolation = auto):
// camera samples traced per pixel, gathers on the adaptive lattice of
// gather_lattice.h, irradiance interpolated to the samples.
#pragma once

#include "server/render/batch_gather.h"
#include "server/render/tile_renderer.h"

namespace pbgi {

// Renders `rect` (validated by render_tile) into `out` (AOVs sized for the
// tile). Gathers go through `gather`; their counters are added to `counters`.
void render_tile_interpolated(const RayScene& rays, const Camera& camera, uint32_t image_width,
                              uint32_t image_height, const TileRect& rect, const RenderOptions& options,
                              const BatchGatherInput& gather, TileAovs& out, GatherCounters& counters);

}  // namespace pbgi
