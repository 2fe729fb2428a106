// Content hashes for the bench's caches: of a scene model (geometry,
// materials, lights: what a render depends on besides the camera) and of a
// camera. Computed from the model itself, so scenes built in code need no
// content_hash of their own.
//
// Thread-safety: pure functions.
#pragma once

#include "server/scene/scene.h"

#include <string>

namespace pbgi::bench {

// 16 hex digits (XXH3-64) of everything in `scene` that light transport
// reads: triangles (positions, normals, indices, materials, sidedness),
// materials, lights and meters_per_unit. Not: paths, cameras, warnings.
std::string scene_model_hash(const Scene& scene);

// 16 hex digits of a camera's transform and lens.
std::string camera_hash(const Camera& camera);

}  // namespace pbgi::bench
