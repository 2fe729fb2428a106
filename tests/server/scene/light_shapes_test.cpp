// CylinderLight sampling against numerical integration over its surface,
// and UsdLuxShapingAPI cones on area lights.
#include "server/scene/direct_lighting.h"
#include "server/scene/light_sampling.h"
#include "server/scene/light_shaping.h"
#include "server/scene/ray_scene.h"
#include "server/scene/rng.h"
#include "server/scene/sample_patterns.h"
#include "tests/server/scene/test_scenes.h"

#include <gtest/gtest.h>

#include <cmath>

namespace pbgi {
namespace {

constexpr double kPiD = 3.14159265358979323846;

Light cylinder(float radius, float length, const M44f& m, const C3f& radiance = C3f(1, 1, 1)) {
  Light l;
  l.prim_path = "/Tube";
  l.kind = LightKind::Cylinder;
  l.local_to_world = m;
  l.radius = radius;
  l.length = length;
  l.radiance = radiance;
  return l;
}

// Irradiance at p (normal n) from a cylinder of radiance 1 around the X
// axis through c, by a midpoint rule over (x, angle) on its lateral
// surface, outward-facing points only.
double integrate_cylinder(float radius, float length, const V3f& c, const V3f& p, const V3f& n) {
  const int nx = 400, na = 800;
  double e = 0.0;
  for (int i = 0; i < nx; ++i)
    for (int j = 0; j < na; ++j) {
      const double x = (i + 0.5) / nx * length - 0.5 * length, a = (j + 0.5) / na * 2 * kPiD;
      const V3f normal(0.f, float(std::cos(a)), float(std::sin(a)));
      const V3f q = c + V3f(float(x), radius * normal.y, radius * normal.z);
      V3f d = p - q;
      const double r2 = d.dot(d);
      d /= std::sqrt(r2);
      const double cos_l = normal.dot(d), cos_r = -n.dot(d);
      if (cos_l <= 0 || cos_r <= 0) continue;
      e += cos_l * cos_r / r2 * (length / nx) * (radius * 2 * kPiD / na);
    }
  return e;
}

// Monte Carlo irradiance from sample_light, without occlusion.
double estimate(const Light& light, const V3f& p, const V3f& n, uint32_t count, uint64_t seed) {
  Rng rng(seed, 0);
  double e = 0.0;
  for (uint32_t k = 0; k < count; ++k) {
    const Imath::V2f u = stratified_sample(k, count, rng);
    const LightSample s = sample_light(light, p, u.x, u.y);
    const float cos_r = n.dot(s.direction);
    if (s.pdf > 0.f && cos_r > 0.f) e += s.radiance.x * cos_r / s.pdf;
  }
  return e / count;
}

TEST(CylinderLight, IrradianceMatchesIntegrationOverItsSurface) {
  M44f m;
  m.setTranslation(V3f(0.5f, 0.f, 2.f));
  const Light light = cylinder(0.4f, 3.f, m);
  for (const auto& [p, n] : {std::pair{V3f(0, 0, 0), V3f(0, 0, 1)}, std::pair{V3f(2.5f, 1.f, 1.5f), V3f(-0.6f, 0, 0.8f)},
                             std::pair{V3f(0.5f, 2.f, 2.f), V3f(0, -1, 0)}}) {
    const double want = integrate_cylinder(0.4f, 3.f, V3f(0.5f, 0.f, 2.f), p, n);
    ASSERT_GT(want, 0.0);
    EXPECT_NEAR(estimate(light, p, n, 16384, 3) / want, 1.0, 0.01) << p;
  }
}

TEST(CylinderLight, SamplesAndRayHitsAgree) {
  // Rotated, then moved (row vectors: r * t applies r first).
  M44f r;
  r.setEulerAngles(V3f(0.3f, -0.2f, 0.7f));
  M44f t;
  t.setTranslation(V3f(1.f, 2.f, 3.f));
  const Light light = cylinder(0.3f, 2.f, r * t, C3f(2, 3, 4));
  const V3f p(3.f, -1.f, 2.f);
  Rng rng(9, 9);
  int hits = 0;
  for (int k = 0; k < 500; ++k) {
    const LightSample s = sample_light(light, p, rng.uniform(), rng.uniform());
    if (!(s.pdf > 0.f)) continue;  // the far side faces away from p
    // Near the silhouette the two roots of the ray-cylinder quadratic merge
    // and single precision cannot place the hit: skip grazing samples.
    const float area = 2.f * float(kPiD) * 0.3f * 2.f;
    if (s.distance * s.distance / (area * s.pdf) < 0.05f) continue;
    C3f radiance;
    float t_hit = 0.f, pdf = 0.f;
    ASSERT_TRUE(intersect_light(light, p, s.direction, 1e30f, &radiance, &t_hit, &pdf)) << k;
    EXPECT_NEAR(t_hit / s.distance, 1.f, 1e-3f);
    EXPECT_NEAR(pdf / s.pdf, 1.f, 1e-2f);
    EXPECT_EQ(radiance, C3f(2, 3, 4));
    ++hits;
  }
  EXPECT_GT(hits, 100);
  // Seen from inside, the cylinder emits away: nothing.
  V3f inside;
  (r * t).multVecMatrix(V3f(0.2f, 0.1f, 0.f), inside);
  EXPECT_EQ(estimate(light, inside, V3f(0, 0, 1), 64, 1), 0.0);
  C3f radiance;
  float t_hit, pdf;
  EXPECT_FALSE(intersect_light(light, inside, V3f(0, 0, 1), 1e30f, &radiance, &t_hit, &pdf));
  // Power: pi * lateral area * mean radiance.
  EXPECT_NEAR(light_power(light), kPiD * 2 * kPiD * 0.3 * 2.0 * 3.0, 1e-3);
}

TEST(CylinderLight, DirectLightingSeesIt) {
  // A floor under a tube along X.
  Scene scene;
  const uint32_t m = test::add_material(scene, C3f(0.5f, 0.5f, 0.5f));
  test::add_square_z(scene, 0.f, 0.f, 0.f, 5.f, m);
  M44f at;
  at.setTranslation(V3f(0.f, 0.f, 1.f));
  scene.lights.push_back(cylinder(0.1f, 2.f, at));
  const RayScene rays(scene);
  const double want = integrate_cylinder(0.1f, 2.f, V3f(0, 0, 1), V3f(0.2f, 0.3f, 0.f), V3f(0, 0, 1));
  const C3f got = direct_irradiance(rays, V3f(0.2f, 0.3f, 0.f), V3f(0, 0, 1), 1024, 5);
  EXPECT_NEAR(got.x / want, 1.0, 0.02);
}

Light rect_down(float z, float size) {
  Light l = test::rect_light(0.f, 0.f, z, size, size, C3f(5.f, 5.f, 5.f));
  return l;
}

TEST(LightShaping, FactorFollowsTheSchema) {
  LightShaping s;
  const V3f axis(0, 0, -1);
  auto dir = [](float degrees) {
    const float a = degrees * float(kPiD) / 180.f;
    return V3f(std::sin(a), 0.f, -std::cos(a));
  };
  EXPECT_EQ(shaping_factor(s, axis, dir(120)), C3f(1, 1, 1));  // disabled
  s.enabled = true;
  s.cone_angle_degrees = 40.f;
  EXPECT_EQ(shaping_factor(s, axis, dir(39)), C3f(1, 1, 1));  // hard cone
  EXPECT_EQ(shaping_factor(s, axis, dir(41)), C3f(0, 0, 0));
  s.cone_softness = 0.5f;  // smooth from 20 to 40 degrees
  EXPECT_EQ(shaping_factor(s, axis, dir(19)), C3f(1, 1, 1));
  EXPECT_NEAR(shaping_factor(s, axis, dir(30)).x, 0.5f, 1e-4f);
  EXPECT_NEAR(shaping_factor(s, axis, dir(25)).x, 1.f - 0.15625f, 1e-4f);  // 1 - smoothstep(0.25)
  EXPECT_EQ(shaping_factor(s, axis, dir(40.5f)), C3f(0, 0, 0));
  s.cone_angle_degrees = 180.f;
  s.focus = 2.f;
  s.focus_tint = C3f(0.f, 0.5f, 1.f);
  const C3f f = shaping_factor(s, axis, dir(60));  // |cos| ^ 2 = 0.25
  EXPECT_NEAR(f.x, 0.25f, 1e-5f);
  EXPECT_NEAR(f.y, 0.5f + 0.5f * 0.25f, 1e-5f);
  EXPECT_NEAR(f.z, 1.f, 1e-5f);
}

TEST(LightShaping, ConeCutsIrradianceOutsideAndKeepsItInside) {
  Scene scene;
  const uint32_t m = test::add_material(scene, C3f(0.5f, 0.5f, 0.5f));
  test::add_square_z(scene, 0.f, 0.f, 0.f, 10.f, m);
  scene.lights.push_back(rect_down(2.f, 0.2f));
  Scene shaped = scene;
  shaped.lights[0].shaping.enabled = true;
  shaped.lights[0].shaping.cone_angle_degrees = 30.f;
  const RayScene plain_rays(scene), shaped_rays(shaped);
  const V3f n(0, 0, 1);
  // Inside the cone (all of the small rect within ~20 degrees): exactly the
  // unshaped estimate (same samples).
  for (const V3f& p : {V3f(0, 0, 0), V3f(0.5f, 0.3f, 0.f)}) {
    const C3f plain = direct_irradiance(plain_rays, p, n, 64, 7);
    const C3f cone = direct_irradiance(shaped_rays, p, n, 64, 7);
    ASSERT_GT(plain.x, 0.f);
    EXPECT_FLOAT_EQ(cone.x, plain.x) << p;
  }
  // Outside (beyond ~33 degrees from every point of the rect): nothing.
  for (const V3f& p : {V3f(2.f, 0, 0), V3f(-1.5f, 1.5f, 0.f)}) {
    EXPECT_GT(direct_irradiance(plain_rays, p, n, 64, 7).x, 0.f);
    EXPECT_EQ(direct_irradiance(shaped_rays, p, n, 64, 7).x, 0.f) << p;
  }
  // Camera rays toward the light from outside the cone see nothing either.
  C3f radiance;
  float t, pdf;
  const V3f from(3.f, 0.f, 0.f);
  ASSERT_TRUE(intersect_light(shaped.lights[0], from, (V3f(0, 0, 2) - from).normalized(), 1e30f, &radiance, &t, &pdf));
  EXPECT_EQ(radiance, C3f(0, 0, 0));
  ASSERT_TRUE(intersect_light(shaped.lights[0], V3f(0.1f, 0, 0), V3f(0, 0, 1), 1e30f, &radiance, &t, &pdf));
  EXPECT_EQ(radiance, C3f(5, 5, 5));
  // Shaped power: the cone passes sin^2(30) of a planar emitter's.
  EXPECT_NEAR(light_power(shaped.lights[0]) / light_power(scene.lights[0]), 0.25f, 1e-5f);
}

TEST(LightShaping, SphereLightConeRestrictsEmissionToItsAxis) {
  Light l;
  l.kind = LightKind::Sphere;
  l.local_to_world.setTranslation(V3f(0, 0, 2));
  l.radius = 0.1f;
  l.radiance = C3f(1, 1, 1);
  l.shaping.enabled = true;
  l.shaping.cone_angle_degrees = 45.f;
  // Below the light (on its -Z axis): lit; beside it and above: dark.
  EXPECT_GT(estimate(l, V3f(0, 0, 0), V3f(0, 0, 1), 64, 1), 0.0);
  EXPECT_EQ(estimate(l, V3f(3, 0, 1.9f), V3f(-1, 0, 0), 64, 1), 0.0);
  EXPECT_EQ(estimate(l, V3f(0, 0, 4), V3f(0, 0, -1), 64, 1), 0.0);
}

}  // namespace
}  // namespace pbgi
