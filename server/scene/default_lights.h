// Light for scenes that bring none. Assets exported for look development
// (a model, its materials, no light rig) would render black: the daemon
// says so in the scene's warnings, and on request (`--default-light`,
// OpenOptions::default_light) lights them with a constant grey dome and a
// distant key light so that the asset can be looked at.
//
// The key light comes from above, in front and to the left of the auto
// camera's side (server/scene/auto_camera.h) in the stage's up-axis
// convention, so that the default view shows lit faces with soft shadows.
#pragma once

#include "server/scene/scene.h"

#include <string>

namespace pbgi {

inline constexpr float kDefaultDomeRadiance = 0.25f;      // W/(sr m^2), grey
inline constexpr float kDefaultKeyIrradiance = 2.5f;      // W/m^2 on a surface facing it
inline constexpr float kDefaultKeyAngleDegrees = 2.f;     // a soft sun
inline constexpr const char* kDefaultDomePath = "/pbgi_default_light/dome";
inline constexpr const char* kDefaultKeyPath = "/pbgi_default_light/key";

// True if anything lights the scene: a UsdLux light, or a material with a
// non-black emission (constant or texture).
bool scene_has_light(const Scene& scene);

// The warning a scene without light gets (SceneInfo.warnings).
std::string no_light_warning();

// Appends the default dome and key light to scene.lights.
void add_default_lights(Scene& scene);

}  // namespace pbgi
