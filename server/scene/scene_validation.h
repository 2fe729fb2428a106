// Structural checks of a Scene's triangle soups (world and prototypes) and instances, run once before anything
// indexes into it (RayScene, surfel sampling) so later stages can index
// without bounds checks.
#pragma once

#include "server/scene/scene.h"

namespace pbgi {

// Throws SceneError naming the scene file and mesh prim if an index is out
// of range or a per-triangle / per-vertex array has the wrong length:
// indices must be a multiple of 3 and < positions.size(); normals empty or
// one per position (uvs and colors too); material one per triangle, each < materials.size();
// mesh empty or one per triangle, each < mesh_paths.size(); double_sided
// empty or one per mesh path.
void validate_scene(const Scene& scene);

// Prim path of the mesh triangle `tri` came from, or "<unknown mesh>".
const std::string& mesh_path_of(const Scene& scene, uint32_t tri);

}  // namespace pbgi
