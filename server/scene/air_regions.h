// Air regions of a scene (storage/tree/region_grid.h; docs/gather.md,
// section 11): which parts of its empty space no path joins, so that
// light emitted into one cannot reach a receiver in another.
//
// The grid: the scene's bulk (scene_bulk.h: far outliers lie outside the
// grid, in no region), padded by two voxels on every side so that
// the outside wraps around everything, cut into cubic voxels (`resolution`
// along the longest side). A voxel a fully opaque triangle overlaps is
// solid (the exact triangle/box test: every closed surface leaves a
// face-connected solid shell, however thin its walls); the others are
// labelled by 6-connected flood fill, in scan order (region 1 holds the
// grid's corner: the outside). Openings narrower than about a voxel close:
// a room whose only window is that narrow counts as closed. Partly
// transparent surfaces (cutouts, fractional opacity) are no walls.
//
// A point on a surface is looked up along its normal: the region of the
// first non-solid voxel in front of it whose centre it sees (a ray that
// meets no surface), so a point within a voxel of another wall does not
// take the region on that wall's far side.
//
// Thread-safety: build_air_regions() is a pure function (parallel inside);
// locate_region() may be called concurrently.
#pragma once

#include "server/scene/ray_scene.h"
#include "server/scene/scene.h"
#include "storage/tree/region_grid.h"

#include <cstdint>

namespace pbgi {

// The grid of `scene` (whose rays `rays` trace), `resolution` (>= 8)
// voxels along its longest side; an empty grid for a scene without
// geometry.
tree::RegionGrid build_air_regions(const Scene& scene, const RayScene& rays, uint32_t resolution);

// The region the front of the surface point (p, unit n) faces, checked by
// rays against `rays` (the scene the grid was built from): tree::kAnyRegion
// when no voxel in front of it is found that it sees. With `guess`, the
// nearest non-solid voxel in front is taken instead of kAnyRegion when
// none is seen (surfels must sort into some region).
uint32_t locate_region(const tree::RegionGrid& grid, const RayScene& rays, const V3f& p, const V3f& n,
                       bool guess = false);

}  // namespace pbgi
