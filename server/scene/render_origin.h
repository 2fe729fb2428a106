// Rendering in a scene-local frame (Scene::render_origin).
//
// A float has 24 bits: at 1e5 units from the world origin positions are
// spaced 0.008 apart, and every quantity computed from them (hit points,
// ray offsets, surfel positions, tree bounds, receiver-to-surfel vectors)
// inherits errors of that size. Subtracting a rendering origin near the
// scene, in double precision, before positions are rounded to float makes
// the scene render exactly as it would at the world origin.
//
// Ingest should compute world positions in double (USD points times a
// double xform) and store world - render_origin; rebase_scene() serves
// scenes already held in float world coordinates (exact: the subtraction of
// a nearby origin loses nothing) and builders that model in double.
#pragma once

#include "server/scene/scene.h"
#include "server/scene/unrepresentable_geometry.h"

namespace pbgi {

using Imath::V3d;

// A rendering origin for `scene`: the world-space centre of the bounds of
// its bulk (scene_bulk.h: the bounds, unless triangles lie far apart --
// one outlier must not move the frame away from the rest of the scene),
// snapped to a multiple of a power of two 1/16 of that box's largest side,
// so that it is exactly representable and small edits of a scene keep it.
// Zero for an empty scene.
V3d render_origin_for(const Scene& scene);

// Re-expresses the scene in the frame at world position `origin`: positions,
// light, camera and volume transforms and volume bounds are moved by
// (render_origin - origin) in double, then rounded to float; render_origin
// becomes `origin`. Directions and normals are unchanged.
void rebase_scene(Scene& scene, const V3d& origin);

// What rebase_to_local_frame() did.
struct LocalFrame {
  V3d origin{0.0, 0.0, 0.0};  // the scene's render_origin now
  bool outliers = false;      // geometry lies apart from the bulk (scene_bulk.h)
  DroppedGeometry dropped;    // what floats could not hold (warnings added)
};

// Moves the scene to its local frame: drops the geometry that floats cannot
// represent there or in the frame it arrived in (unrepresentable_geometry.h,
// a warning per prim in scene.warnings), then rebase_scene(scene,
// render_origin_for(scene)). Throws SceneError (naming a dropped prim) if
// nothing is left.
LocalFrame rebase_to_local_frame(Scene& scene);

// Local <-> world conversions of points.
inline V3f to_local(const Scene& scene, const V3d& world) {
  const V3d l = world - scene.render_origin;
  return V3f(float(l.x), float(l.y), float(l.z));
}
inline V3d to_world(const Scene& scene, const V3f& local) {
  return scene.render_origin + V3d(local.x, local.y, local.z);
}

}  // namespace pbgi
