#include "server/scene/default_lights.h"

namespace pbgi {
namespace {

bool black(const C3f& c) { return !(c.x > 0.f || c.y > 0.f || c.z > 0.f); }

}  // namespace

bool scene_has_light(const Scene& scene) {
  if (!scene.lights.empty()) return true;
  for (const Material& m : scene.materials) {
    if (!black(m.emission) || !m.emission_texture.file.empty()) return true;
  }
  return false;
}

std::string no_light_warning() {
  return "the scene has no light (no UsdLux light, no emissive material): it renders black; "
         "pass --default-light (BuildOptions.default_light) for a dome and a key light";
}

void add_default_lights(Scene& scene) {
  Light dome;
  dome.prim_path = kDefaultDomePath;
  dome.kind = LightKind::Dome;
  dome.radiance = C3f(kDefaultDomeRadiance);
  scene.lights.push_back(dome);

  // Towards the key light in a Y-up frame (above, in front, to the left),
  // mapped to Z-up like auto_camera's view direction.
  V3f to_light = V3f(-0.45f, 0.8f, 0.4f).normalized();
  V3f up(0.f, 1.f, 0.f);
  if (scene.up_axis == "Z") {
    to_light = V3f(to_light.x, -to_light.z, to_light.y);
    up = V3f(0.f, 0.f, 1.f);
  }
  // A distant light shines down its local -Z axis: +Z points at the light.
  const V3f z = to_light;
  const V3f x = up.cross(z).normalized();
  const V3f y = z.cross(x);
  Light key;
  key.prim_path = kDefaultKeyPath;
  key.kind = LightKind::Distant;
  key.local_to_world = M44f(x.x, x.y, x.z, 0.f, y.x, y.y, y.z, 0.f, z.x, z.y, z.z, 0.f, 0.f, 0.f, 0.f, 1.f);
  key.radiance = C3f(kDefaultKeyIrradiance);
  key.angle_degrees = kDefaultKeyAngleDegrees;
  scene.lights.push_back(key);
}

}  // namespace pbgi
