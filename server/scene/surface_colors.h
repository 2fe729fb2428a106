// Albedo and emission of a point on the scene's triangles: the material's
// constants, or its textures at the point's texture coordinates, or the
// mesh's vertex colours (textures win over vertex colours, which win over
// constants). Shared by surfel sampling, the tile renderer and the
// reference path tracer so that all of them see the same surface.
//
// Where a textured material meets a mesh without texture coordinates, the
// texture's mean is used (and a constant-st binding its one value).
//
// Thread-safety: reentrant; the scene is only read.
#pragma once

#include "server/scene/scene.h"

#include <cstdint>

namespace pbgi {

struct SurfaceColors {
  C3f albedo{0, 0, 0};
  C3f emission{0, 0, 0};
};

// At barycentrics (b1, b2) of `triangle` (the weights of its vertices 1 and
// 2, as Embree's hit u, v). `footprint` is the world-space width of the area
// the value stands for (a surfel's diameter; 0 = the point): textures are
// averaged over it through their mip pyramid.
SurfaceColors surface_colors(const Scene& scene, uint32_t triangle, float b1, float b2,
                             float footprint = 0.f);

// True if the material's colours vary over its surfaces.
bool has_varying_colors(const Material& material);

}  // namespace pbgi
