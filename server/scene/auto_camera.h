// `--camera auto`: a camera framing the scene's world bounds, for scenes
// without a UsdGeom.Camera (or when the client asks for it).
//
// Default direction: the camera looks at the centre of the scene's bounds
// (the bulk's triangles, server/scene/scene_bulk.h -- not a far outlier's
// box -- and volumes) from
// azimuth kAutoCameraAzimuthDegrees (30 deg, from the stage's front axis
// toward +X) and elevation kAutoCameraElevationDegrees (20 deg above the
// horizon), in the stage's up-axis convention: with upAxis Y the front is
// +Z (the camera sits on the +Z side, +Y up), with upAxis Z the front is -Y
// (+Z up), so both conventions get the same view of the same model.
//
// Framing: the bounding sphere of the bounds fits the narrower field of
// view with kAutoCameraMargin to spare; the lens is USD's fallback (focal
// length 50 mm, horizontal aperture 20.955 mm), the vertical aperture
// follows `aspect` (width / height), the clipping range encloses the sphere
// with room on both sides. prim_path is "auto". A scene without geometry
// gets the same view of a unit sphere around the origin.
//
// Pure function of its inputs: thread-safe.
#pragma once

#include "server/scene/scene.h"

namespace pbgi {

inline constexpr float kAutoCameraAzimuthDegrees = 30.f;
inline constexpr float kAutoCameraElevationDegrees = 20.f;
inline constexpr float kAutoCameraMargin = 1.1f;  // sphere radius scale
inline constexpr const char* kAutoCameraPath = "auto";

// Throws InvalidArgument unless aspect is finite and > 0.
Camera auto_camera(const Scene& scene, float aspect);

// The same for given bounds and up axis ("Y" or "Z"; anything else is Y).
Camera auto_camera(const Box3f& bounds, const std::string& up_axis, float aspect);

// The camera a request names, for an image of `aspect` (width / height):
//   a prim path        that camera of the scene;
//   "auto"             the auto camera (unless the scene has a camera prim
//                      of that name, which wins);
//   ""                 the scene's only camera, or the auto camera if it has
//                      none.
// Every client (render, tile, reference, bench, the Python client) resolves
// names this way, so a scene without a camera renders with no flag. Throws
// NotFound naming the scene's cameras for an unknown path or for "" with
// several cameras; InvalidArgument for a bad aspect.
Camera resolve_camera(const Scene& scene, const std::string& path, float aspect);

}  // namespace pbgi
