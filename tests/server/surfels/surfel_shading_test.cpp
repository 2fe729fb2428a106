#include "server/surfels/surfels.h"
#include "tests/server/scene/test_scenes.h"

#include <gtest/gtest.h>

#include <cmath>

namespace pbgi {
namespace {

constexpr float kAlbedo = 0.6f;

// Floor [-1.5,1.5]^2 under a 1x1 rect light at height 1, with an optional
// 1.2 x 1.2 blocker at height 0.5 that is larger than the light.
Scene floor_under_light(bool blocker) {
  Scene s;
  const uint32_t m = test::add_material(s, {kAlbedo, kAlbedo, kAlbedo});
  test::add_square_z(s, 0, 0, 0, 1.5f, m, false, "/floor");
  if (blocker) test::add_square_z(s, 0, 0, 0.5f, 0.6f, m, true, "/blocker");
  s.lights.push_back(test::rect_light(0, 0, 1.f, 1.f, 1.f, {3.f, 3.f, 3.f}));
  return s;
}

TEST(ShadeDirect, PlaneUnderRectLightMatchesAnalytic) {
  const Scene s = floor_under_light(false);
  const RayScene rays(s);
  SurfelOptions o;
  o.target_surfels = 300;
  o.light_samples = 256;
  auto surfels = sample_surfels(s, o);
  ASSERT_GT(surfels.size(), 250u);
  shade_direct(rays, o, surfels);
  double worst = 0;
  for (const Surfel& x : surfels) {
    const double e =
        test::rect_irradiance(3.0, -0.5, 0.5, -0.5, 0.5, x.position.x, x.position.y, 1.0);
    const double expected = kAlbedo / M_PI * e;
    worst = std::max(worst, std::fabs(x.radiance.x - expected) / expected);
  }
  EXPECT_LT(worst, 0.02);
}

TEST(ShadeDirect, SurfelInShadowGetsNoLight) {
  const Scene s = floor_under_light(true);
  const RayScene rays(s);
  SurfelOptions o;
  o.target_surfels = 2000;
  auto surfels = sample_surfels(s, o);
  shade_direct(rays, o, surfels);
  size_t umbra = 0, lit = 0;
  for (const Surfel& x : surfels) {
    if (x.position.z != 0.f) continue;  // blocker surfels
    const float r = std::max(std::fabs(x.position.x), std::fabs(x.position.y));
    // The umbra of a 1.2-wide blocker halfway to a 1-wide light is |x|,|y| < 0.1.
    if (r < 0.09f) {
      EXPECT_EQ(x.radiance, C3f(0, 0, 0)) << x.position;
      ++umbra;
    }
    if (r > 1.2f) lit += x.radiance.x > 0.f;
  }
  EXPECT_GT(umbra, 0u);
  EXPECT_GT(lit, 0u);
}

TEST(ShadeDirect, AddsToEmissionAndIsDeterministic) {
  Scene s = floor_under_light(false);
  s.materials[0].emission = C3f(0.25f, 0.5f, 1.f);
  const RayScene rays(s);
  SurfelOptions o;
  o.target_surfels = 200;
  auto a = sample_surfels(s, o);
  auto b = a;
  shade_direct(rays, o, a);
  shade_direct(rays, o, b);
  for (size_t i = 0; i < a.size(); ++i) {
    ASSERT_EQ(a[i].radiance, b[i].radiance);
    // Gray light, gray albedo: the reflected part is equal in all channels.
    EXPECT_NEAR(a[i].radiance.x - 0.25f, a[i].radiance.z - 1.f, 1e-5f);
    EXPECT_GT(a[i].radiance.x, 0.25f);
  }
}

TEST(ShadeDirect, ReportsProgressInOrder) {
  const Scene s = floor_under_light(false);
  const RayScene rays(s);
  SurfelOptions o;
  o.target_surfels = 5000;
  o.light_samples = 1;
  auto surfels = sample_surfels(s, o);
  std::vector<float> seen;
  shade_direct(rays, o, surfels, [&](const char* stage, float f) {
    EXPECT_STREQ(stage, "shade_direct");
    seen.push_back(f);
  });
  ASSERT_GE(seen.size(), 10u);
  EXPECT_LE(seen.size(), 102u);
  EXPECT_TRUE(std::is_sorted(seen.begin(), seen.end()));
  EXPECT_EQ(seen.back(), 1.f);
}

}  // namespace
}  // namespace pbgi
