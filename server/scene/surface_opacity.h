// Opacity of the scene's surfaces, one model for every consumer (camera,
// path and shadow rays through RayScene; surfel sampling), so that PBGI and
// the reference path tracer see the same holes:
//
// * cutout (Material::opacity_threshold > 0, UsdPreviewSurface's
//   opacityThreshold): the surface is present where its opacity is at
//   least the threshold and absent elsewhere -- rays pass through, and no
//   surfel is made there;
// * fractional (threshold 0, opacity < 1): the surface is present with
//   probability `opacity` per ray (stochastic transparency: each ray
//   decides by a hash of itself and the triangle, so a shadow ray's
//   expected transmission is 1 - opacity and a camera ray's expected
//   colour the opacity-weighted blend), and a surfel there covers
//   `opacity` of its area (its radius scaled by sqrt(opacity)): it reflects,
//   emits and occludes that fraction, as the rays see on average.
//
// At a few samples per pixel (PBGI's camera and light samples) a
// fractional surface and its shadow are grainy; their means match the
// reference's (tests/stability/cutout_test.cpp). Refraction and coloured
// transmission are not modelled: opacity is presence, not glass.
//
// Thread-safety: reentrant; the scene is only read.
#pragma once

#include "server/scene/scene.h"

#include <cstdint>

namespace pbgi {

// True if the material is not fully opaque everywhere.
bool has_opacity(const Material& material);

// Opacity in [0, 1] at barycentrics (u, v) of triangle `triangle` of `soup`
// in the soup's own vertex order (Embree's hit u, v within that soup).
float soup_opacity(const TriangleSoup& soup, const Material& material, uint32_t triangle, float u, float v);

// Whether a ray identified by `ray_hash` meets the surface there: the
// cutout test, or hash < opacity for fractional opacity.
bool surface_present(const Material& material, float opacity, uint32_t ray_hash);

// The fraction of a surfel's area that is surface at scene triangle
// `triangle`, barycentrics (b1, b2) in world winding order (as
// surface_colors): 0 where a cutout removes it, the opacity where it is
// fractional, 1 for opaque materials.
float surface_coverage(const Scene& scene, uint32_t triangle, float b1, float b2);

}  // namespace pbgi
