// Where the bulk of a scene's surface lies, apart from far outliers.
//
// Everything that sizes itself from the scene's extent -- the rendering
// origin (render_origin.h), the Morton cube that orders the surfels, the
// ray-offset bound, the adaptive sampler's finest spacing -- would let one
// tiny triangle 1e10 units away make that extent 1e10: the Cornell box
// then collapses into one float step. They use the bulk's bounds instead.
//
// The bulk: per axis, the 1st and 99th area-weighted percentiles of the
// triangles' centroids give a box; every triangle (instances: every
// instance, by the centre of its box) whose centroid lies within that
// box's geometry grown by twice its largest side on every side belongs to
// the bulk. Anything holding more than 1% of the area is in the bulk, so a
// scene without far outliers has bulk bounds ==
// Scene::bounds() exactly (same box, same results as before outliers were
// handled); a large far object is bulk too, and the precision check
// (unrepresentable_geometry.h) decides what floats can still hold.
//
// Cost: one pass over the triangles and instances, a sort of at most 2^20
// samples per axis (a deterministic stride over larger scenes), and a
// second pass when something lies apart.
//
// Thread-safety: reads the scene only.
#pragma once

#include "server/scene/scene.h"

#include <cstdint>

namespace pbgi {

struct SceneBulk {
  // Bounds of the bulk's vertices, in the scene's frame (as Scene::bounds():
  // instances vertex by vertex, non-finite positions left out). Equal to
  // Scene::bounds() when nothing lies apart.
  Box3f bounds;
  // Triangles outside the bulk (an instance counts its prototype's).
  uint64_t outlying_triangles = 0;
  // The largest side of an outlying triangle's box (of an outlying
  // instance's box): with the bulk's largest side it bounds every
  // triangle's size, which ray offsets depend on (RayScene::point_error).
  float outlying_extent = 0.f;

  bool has_outliers() const { return outlying_triangles > 0; }
};

SceneBulk scene_bulk(const Scene& scene);

}  // namespace pbgi
