// Geometry that float coordinates cannot hold where it lies.
//
// A scene is stored in one float frame (Scene::render_origin). Far from
// that frame's origin float steps grow (1024 units at 1e10, 8.8e12 at
// 1e20): a triangle smaller than a few steps there has lost its shape --
// its corners rounded onto one or two points, or moved by a sizeable part
// of its size -- and the scene's float bounds, ray offsets and tree
// quantization would carry those steps. Such geometry is dropped, and each
// prim that lost some is named in Scene::warnings (which reach the client
// in SceneInfo.warnings and the daemon's log).
//
// What counts: a world triangle whose longest edge spans fewer than
// kMinFloatSteps float steps at its largest coordinate, or an instance
// whose whole box does (an instance is judged as a whole: one whose
// triangles are tiny but whose box is not stays), either
//  - in the local frame at the new origin though not in the frame the
//    scene arrived in: the new frame would destroy it (also where the
//    local coordinates overflow floats); or
//  - in the frame the scene arrived in, where float steps are coarser than
//    at any point of the bulk's bounds (scene_bulk.h): it was destroyed
//    before the daemon saw it (ingest rounds world positions to float).
//    Within the bulk's steps a small or degenerate triangle is input as
//    authored, left to the samplers (they skip zero areas).
//
// Thread-safety: modifies `scene`; not concurrent with readers of it.
#pragma once

#include "server/scene/scene.h"

#include <cstdint>

namespace pbgi {

inline constexpr double kMinFloatSteps = 8.0;

struct DroppedGeometry {
  uint64_t triangles = 0;  // world triangles dropped
  uint64_t instances = 0;  // instances dropped (all their triangles)

  bool any() const { return triangles > 0 || instances > 0; }
};

// Drops what the scene's current frame or the local frame at `origin`
// (world position, double) cannot represent, judged against `bulk`
// (scene_bulk(scene).bounds, in the current frame). Unreferenced vertices
// are removed with the triangles, so Scene::bounds() forgets them; the
// instances left are renumbered. Appends one warning per prim (at most
// kMaxPrecisionWarnings, then a count of the rest).
inline constexpr size_t kMaxPrecisionWarnings = 16;
DroppedGeometry drop_unrepresentable_geometry(Scene& scene, const Imath::V3d& origin, const Box3f& bulk);

}  // namespace pbgi
