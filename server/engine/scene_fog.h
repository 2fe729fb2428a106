// Step 2b of open_scene: the scene's fog grids (Scene::volumes, kind Fog)
// into light transport. A FogField (server/volumes/fog_field.h) becomes the
// RayScene's medium, so every shadow ray -- surfel shading, the tile
// renderer's direct light, the reference -- is attenuated by it; fog points
// baked at the surfel spacing's level of detail and lit by single
// scattering (server/volumes/fog_points.h) go to every Gatherer
// (SceneSession::fog), where they attenuate and add light to the
// microbuffer. The FogOptions (OpenOptions::fog: the daemon's [fog]
// config table) are folded into the content hash so page sets built with
// fog are not reused without it or with other fog options.
#pragma once

#include "server/engine/scene_session.h"

namespace pbgi {

// Does nothing for a scene without fog (no loaded fog grid with active
// voxels). `spacing` is the surfel spacing in world units (> 0).
void prepare_fog(SceneSession& session, float spacing, const FogOptions& options);

}  // namespace pbgi
