// Renders one tile of a camera's image through PBGI: primary hits with
// Embree, direct light with shadow rays, indirect diffuse light from the
// gather. Produces the AOVs the service returns.
#pragma once

#include "server/gather/gather.h"
#include "server/render/camera_sample.h"
#include "server/render/gather_lattice.h"
#include "server/render/render_options.h"
#include "server/scene/ray_scene.h"

#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

namespace pbgi {

struct TileRect {
  uint32_t x0 = 0, y0 = 0, x1 = 0, y1 = 0;   // [x0,x1) x [y0,y1), y down from the top
  uint32_t width() const { return x1 - x0; }
  uint32_t height() const { return y1 - y0; }
};

// Row-major AOVs of a tile: rgb layers have 3 floats per pixel, ao has 1.
// "indirect" is the gathered light reflected by the hit's BRDF
// (server/scene/brdf.h): its diffuse lobe times the irradiance, plus, for
// materials with a GGX lobe, the glossy gather towards the camera; the
// same quantity as the reference's "indirect" (path_tracer.h) with one
// bounce in the surfels. "direct" still treats every surface as Lambert
// (albedo / pi): a glossy material's direct highlight is not rendered.
struct TileAovs {
  TileRect rect;
  std::vector<float> beauty, direct, indirect, albedo, ao;
  uint64_t camera_samples = 0;  // traced in the tile (gathers: GatherCounters::receivers)

  void resize(const TileRect& r);                           // zeroed layers for r
  void store(size_t pixel, const PixelValue& sum, float scale);  // pixel = row-major index in rect
};

// With interpolation on (the default), the tile's camera samples are traced
// first, then gathered at the adaptive lattice of gather_lattice.h. With it
// off, every camera sample is gathered: PBGI gathers each pixel sample as
// its row is traced; factorized PBGI traces the whole tile first, then
// gathers its receivers in batches of 1024 (in scan order) so that nearby
// receivers share their far light. The tile's gatherers share one
// GatherCache.
// `fog`: the scene's fog volume points (SceneSession::fog) for the
// gathers; the rays' medium attenuates direct light.
// Throws InvalidArgument if the tile is empty or outside the image,
// Cancelled if `cancelled` returns true while rendering.
TileAovs render_tile(const RayScene& rays, const tree::TreeSource& tree, const Camera& camera,
                     uint32_t image_width, uint32_t image_height, const TileRect& rect,
                     const RenderOptions& options, GatherCounters* counters = nullptr,
                     const std::function<bool()>& cancelled = {},
                     std::shared_ptr<const VolumePoints> fog = nullptr);

}  // namespace pbgi
