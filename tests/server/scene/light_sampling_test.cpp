#include "server/scene/light_sampling.h"
#include "server/scene/rng.h"
#include "server/scene/sample_patterns.h"
#include "tests/server/scene/test_scenes.h"

#include <gtest/gtest.h>

#include <cmath>

namespace pbgi {
namespace {

// Monte Carlo irradiance at p with normal n from one light, no occlusion,
// with an n x n stratified grid.
double irradiance(const Light& light, const V3f& p, const V3f& n, uint32_t grid) {
  Rng rng(7);
  double e = 0.0;
  const uint32_t count = grid * grid;
  for (uint32_t k = 0; k < count; ++k) {
    const Imath::V2f u = stratified_sample(k, count, rng);
    const LightSample s = sample_light(light, p, u.x, u.y);
    if (!(s.pdf > 0.f)) continue;
    const float c = n.dot(s.direction);
    if (c > 0.f) e += s.radiance.x * c / s.pdf;
  }
  return e / count;
}

TEST(LightSampling, RectIrradianceOnAxisMatchesAnalytic) {
  const float side = 1.f, height = 0.8f, L = 3.f;
  const Light light = test::rect_light(0, 0, height, side, side, {L, L, L});
  const double analytic = test::rect_irradiance(L, -0.5, 0.5, -0.5, 0.5, 0, 0, height);
  // Sanity of the closed form: a far, small light behaves like a point.
  EXPECT_NEAR(test::rect_irradiance(1, -0.01, 0.01, -0.01, 0.01, 0, 0, 10), 0.0004 / 100, 1e-8);
  const double mc = irradiance(light, V3f(0, 0, 0), V3f(0, 0, 1), 64);
  EXPECT_NEAR(mc / analytic, 1.0, 0.01) << "mc " << mc << " analytic " << analytic;
}

TEST(LightSampling, RectIrradianceOffAxisMatchesAnalytic) {
  const Light light = test::rect_light(0.3f, -0.2f, 1.f, 2.f, 0.5f, {1, 1, 1});
  const double analytic = test::rect_irradiance(1, -0.7, 1.3, -0.45, 0.05, 0.9, 0.4, 1.0);
  const double mc = irradiance(light, V3f(0.9f, 0.4f, 0), V3f(0, 0, 1), 64);
  EXPECT_NEAR(mc / analytic, 1.0, 0.01);
}

TEST(LightSampling, RectIsOneSided) {
  const Light light = test::rect_light(0, 0, 1, 1, 1, {1, 1, 1});
  const LightSample above = sample_light(light, V3f(0, 0, 2), 0.5f, 0.5f);
  EXPECT_EQ(above.pdf, 0.f);
  const LightSample below = sample_light(light, V3f(0, 0, 0), 0.5f, 0.5f);
  EXPECT_NEAR(below.pdf, 1.f, 1e-6f);  // d^2 / (A cos) = 1 / (1 * 1)
  EXPECT_NEAR(below.direction.z, 1.f, 1e-6f);
  EXPECT_NEAR(below.distance, 1.f, 1e-6f);
  C3f l;
  float t, pdf;
  EXPECT_TRUE(intersect_light(light, V3f(0, 0, 0), V3f(0, 0, 1), 10.f, &l, &t, &pdf));
  EXPECT_FALSE(intersect_light(light, V3f(0, 0, 2), V3f(0, 0, -1), 10.f, &l, &t, &pdf));
  EXPECT_FALSE(intersect_light(light, V3f(0, 0, 0), V3f(0, 0, 1), 0.5f, &l, &t, &pdf));  // tmax
}

// A rect light rotated to emit toward world +Y, scaled non-uniformly:
// rows of a USD matrix are the images of the local axes.
Light rotated_rect() {
  Light l = test::rect_light(0, 0, 0, 1.f, 0.5f, {2, 2, 2});
  l.local_to_world = M44f(2, 0, 0, 0,    // local X -> world X, scaled 2
                          0, 0, 3, 0,    // local Y -> world Z, scaled 3
                          0, -1, 0, 0,   // local Z -> world -Y, so -Z emits toward +Y
                          1, 2, 3, 1);   // translation
  return l;
}

TEST(LightSampling, TransformedRectSamplesAndIntersectionsAgree) {
  const Light light = rotated_rect();
  const M44f inv = light.local_to_world.inverse();
  const V3f p(1.3f, 4.f, 2.5f);  // on the emitting (+Y) side
  Rng rng(3);
  for (int i = 0; i < 200; ++i) {
    const LightSample s = sample_light(light, p, rng.uniform(), rng.uniform());
    ASSERT_GT(s.pdf, 0.f);
    // The sampled point lies on the rectangle in local space.
    V3f local;
    inv.multVecMatrix(p + s.distance * s.direction, local);
    EXPECT_LE(std::fabs(local.x), 0.5f + 1e-4f);
    EXPECT_LE(std::fabs(local.y), 0.25f + 1e-4f);
    EXPECT_NEAR(local.z, 0.f, 1e-4f);
    // A ray along the sample finds the light at that distance with that pdf.
    C3f l;
    float t, pdf;
    ASSERT_TRUE(intersect_light(light, p, s.direction, 1e30f, &l, &t, &pdf));
    EXPECT_NEAR(t, s.distance, 1e-4f * s.distance);
    EXPECT_NEAR(pdf / s.pdf, 1.f, 1e-3f);
    EXPECT_EQ(l, C3f(2, 2, 2));
  }
  EXPECT_EQ(sample_light(light, V3f(1.3f, 0.f, 2.5f), 0.5f, 0.5f).pdf, 0.f);  // behind
  // World area 2*1 x 3*0.5 = 3; pi * A * L.
  EXPECT_NEAR(light_power(light), M_PI * 3.0 * 2.0, 1e-3);
}

TEST(LightSampling, SphereIrradianceMatchesAnalytic) {
  Light light;
  light.kind = LightKind::Sphere;
  light.radius = 0.5f;
  light.radiance = C3f(1, 1, 1);
  light.local_to_world.makeIdentity();
  light.local_to_world.setTranslation(V3f(0, 0, 2));
  // Facing the center: E = pi L sin^2(theta_max).
  const double analytic = M_PI * (0.5 * 0.5) / (2.0 * 2.0);
  EXPECT_NEAR(irradiance(light, V3f(0, 0, 0), V3f(0, 0, 1), 32) / analytic, 1.0, 0.01);
  // A very small, far sphere takes the Taylor branch.
  light.radius = 0.01f;
  light.local_to_world.setTranslation(V3f(0, 0, 10));
  EXPECT_NEAR(irradiance(light, V3f(0, 0, 0), V3f(0, 0, 1), 16) / (M_PI * 1e-6), 1.0, 0.01);
  // Sampled points are on the sphere and hit by intersect_light.
  Rng rng(5);
  for (int i = 0; i < 100; ++i) {
    const LightSample s = sample_light(light, V3f(0, 0, 0), rng.uniform(), rng.uniform());
    const V3f q = s.distance * s.direction;
    EXPECT_NEAR((q - V3f(0, 0, 10)).length(), 0.01f, 1e-4f);
    C3f l;
    float t, pdf;
    ASSERT_TRUE(intersect_light(light, V3f(0, 0, 0), s.direction, 1e30f, &l, &t, &pdf));
    EXPECT_NEAR(pdf / s.pdf, 1.f, 1e-3f);
  }
}

TEST(LightSampling, DiskIrradianceOnAxisMatchesAnalytic) {
  Light light;
  light.kind = LightKind::Disk;
  light.radius = 0.7f;
  light.radiance = C3f(1, 1, 1);
  light.local_to_world.makeIdentity();
  light.local_to_world.setTranslation(V3f(0, 0, 1.5f));
  const double analytic = M_PI * 0.49 / (0.49 + 2.25);
  EXPECT_NEAR(irradiance(light, V3f(0, 0, 0), V3f(0, 0, 1), 64) / analytic, 1.0, 0.01);
  C3f l;
  float t, pdf;
  EXPECT_TRUE(intersect_light(light, V3f(0.6f, 0, 0), V3f(0, 0, 1), 10.f, &l, &t, &pdf));
  EXPECT_FALSE(intersect_light(light, V3f(0.6f, 0.6f, 0), V3f(0, 0, 1), 10.f, &l, &t, &pdf));
}

TEST(LightSampling, DistantIsDeltaFromLocalPlusZ) {
  Light light;
  light.kind = LightKind::Distant;
  light.radiance = C3f(4, 4, 4);
  // Rotate local Z onto world (0, 0.6, 0.8): the light arrives from there.
  light.local_to_world = M44f(1, 0, 0, 0, 0, 0.8f, -0.6f, 0, 0, 0.6f, 0.8f, 0, 0, 0, 0, 1);
  const LightSample s = sample_light(light, V3f(0, 0, 0), 0.3f, 0.7f);
  EXPECT_TRUE(s.delta);
  EXPECT_EQ(s.pdf, 1.f);
  EXPECT_TRUE(std::isinf(s.distance));
  EXPECT_NEAR(s.direction.y, 0.6f, 1e-6f);
  EXPECT_NEAR(s.direction.z, 0.8f, 1e-6f);
  // Irradiance-normalized: E on the floor = L cos(theta).
  EXPECT_NEAR(irradiance(light, V3f(0, 0, 0), V3f(0, 0, 1), 1), 4.0 * 0.8, 1e-5);
  C3f l;
  float t, pdf;
  EXPECT_FALSE(intersect_light(light, V3f(0, 0, 0), s.direction, 1e30f, &l, &t, &pdf));
}

}  // namespace
}  // namespace pbgi
