#include "server/scene/direct_lighting.h"
#include "tests/server/scene/test_scenes.h"

#include <gtest/gtest.h>

namespace pbgi {
namespace {

// Floor [-2,2]^2 at z = 0 under a 1x1 rect light at height 1.
Scene lit_floor() {
  Scene s;
  const uint32_t m = test::add_material(s, {0.5f, 0.5f, 0.5f});
  test::add_square_z(s, 0, 0, 0, 2.f, m, false, "/floor");
  s.lights.push_back(test::rect_light(0, 0, 1.f, 1.f, 1.f, {2.f, 1.f, 0.5f}));
  return s;
}

TEST(DirectLighting, UnshadowedMatchesAnalytic) {
  const Scene s = lit_floor();
  const RayScene rays(s);
  for (const V3f& p : {V3f(0, 0, 0), V3f(0.7f, -0.4f, 0)}) {
    const double analytic = test::rect_irradiance(2.0, -0.5, 0.5, -0.5, 0.5, p.x, p.y, 1.0);
    const C3f e = direct_irradiance(rays, p, V3f(0, 0, 1), 1024, 11);
    EXPECT_NEAR(e.x / analytic, 1.0, 0.01);
    EXPECT_NEAR(e.y / e.x, 0.5f, 1e-5f);  // color carried through
    EXPECT_NEAR(e.z / e.x, 0.25f, 1e-5f);
  }
}

TEST(DirectLighting, BlockerCastsShadow) {
  Scene s = lit_floor();
  // A 2x2 blocker at z = 0.5, larger than the light: full umbra below it.
  test::add_square_z(s, 0, 0, 0.5f, 1.f, 0, true, "/blocker");
  const RayScene rays(s);
  EXPECT_EQ(direct_irradiance(rays, V3f(0, 0, 0), V3f(0, 0, 1), 64, 3), C3f(0, 0, 0));
  // Far to the side the light is visible under the blocker's edge.
  EXPECT_GT(direct_irradiance(rays, V3f(1.9f, 0, 0), V3f(0, 0, 1), 64, 3).x, 0.f);
}

TEST(DirectLighting, OnlyTheHemisphereAroundTheNormal) {
  const Scene s = lit_floor();
  const RayScene rays(s);
  EXPECT_EQ(direct_irradiance(rays, V3f(0, 0, 0.2f), V3f(0, 0, -1), 64, 3), C3f(0, 0, 0));
}

TEST(DirectLighting, DeterministicPerSeed) {
  const Scene s = lit_floor();
  const RayScene rays(s);
  const V3f p(0.3f, 0.2f, 0);
  const C3f a = direct_irradiance(rays, p, V3f(0, 0, 1), 16, 42);
  const C3f b = direct_irradiance(rays, p, V3f(0, 0, 1), 16, 42);
  const C3f c = direct_irradiance(rays, p, V3f(0, 0, 1), 16, 43);
  EXPECT_EQ(a, b);
  EXPECT_NE(a, c);
}

TEST(DirectLighting, CoplanarLightHousingDoesNotShadow) {
  Scene s = lit_floor();
  // A quad at the light's own position (a fixture modelled with the light).
  test::add_square_z(s, 0, 0, 1.f, 0.5f, 0, true, "/housing");
  const RayScene rays(s);
  const double analytic = test::rect_irradiance(2.0, -0.5, 0.5, -0.5, 0.5, 0, 0, 1.0);
  EXPECT_NEAR(direct_irradiance(rays, V3f(0, 0, 0), V3f(0, 0, 1), 256, 1).x / analytic, 1.0, 0.02);
}

}  // namespace
}  // namespace pbgi
