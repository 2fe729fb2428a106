// Scenes that bring no light: detected (UsdLux lights and emissive
// materials both count), and lit on request by a dome and a key light that
// comes from above in either up-axis convention.
#include "server/scene/default_lights.h"
#include "server/scene/light_sampling.h"
#include "tests/server/scene/test_scenes.h"

#include <gtest/gtest.h>

namespace pbgi {
namespace {

TEST(DefaultLights, LightsAndEmissiveMaterialsCountAsLight) {
  Scene s;
  test::add_material(s, {0.5f, 0.5f, 0.5f});
  EXPECT_FALSE(scene_has_light(s));
  s.materials[0].emission_texture.file = "/tex/glow.png";
  EXPECT_TRUE(scene_has_light(s));
  s.materials[0].emission_texture.file.clear();
  s.materials[0].emission = C3f(0.f, 0.f, 1.f);
  EXPECT_TRUE(scene_has_light(s));
  Scene lit;
  lit.lights.push_back(test::rect_light(0, 0, 1.f, 1.f, 1.f, {1.f, 1.f, 1.f}));
  EXPECT_TRUE(scene_has_light(lit));
}

TEST(DefaultLights, DomeAndKeyLightFromAboveInBothUpAxes) {
  for (const char* up : {"Y", "Z"}) {
    Scene s;
    s.up_axis = up;
    add_default_lights(s);
    ASSERT_TRUE(scene_has_light(s));
    ASSERT_EQ(s.lights.size(), 2u);
    EXPECT_EQ(s.lights[0].kind, LightKind::Dome);
    EXPECT_EQ(s.lights[0].radiance, C3f(kDefaultDomeRadiance));
    const Light& key = s.lights[1];
    EXPECT_EQ(key.kind, LightKind::Distant);
    const LightSample k = sample_light(key, V3f(0.f), 0.5f, 0.5f);
    const V3f upward = std::string(up) == "Z" ? V3f(0, 0, 1) : V3f(0, 1, 0);
    EXPECT_NEAR(k.direction.length(), 1.f, 1e-5f);
    EXPECT_GT(k.direction.dot(upward), 0.7f) << up;  // well above the horizon
    EXPECT_EQ(k.radiance, C3f(kDefaultKeyIrradiance));
  }
}

}  // namespace
}  // namespace pbgi
