// DomeLights: the lat-long convention, importance sampling of a map, and
// the irradiance they give on an open plane against closed forms and
// numerical integration of the map.
#include "server/scene/direct_lighting.h"
#include "server/scene/dome_light.h"
#include "server/scene/environment_map.h"
#include "server/scene/ray_scene.h"
#include "server/scene/rng.h"
#include "server/scene/sample_patterns.h"
#include "tests/server/scene/test_scenes.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>

namespace pbgi {
namespace {

constexpr double kPiD = 3.14159265358979323846;

void expect_dir(const V3f& got, const V3f& want) {
  EXPECT_NEAR(got.x, want.x, 1e-5f) << "x";
  EXPECT_NEAR(got.y, want.y, 1e-5f) << "y";
  EXPECT_NEAR(got.z, want.z, 1e-5f) << "z";
}

TEST(EnvironmentMap, LatLongFollowsOpenExr) {
  // Centre column faces +Z, a quarter in from the left +X, the top row +Y.
  expect_dir(EnvironmentMap::uv_to_direction({0.5f, 0.5f}), V3f(0, 0, 1));
  expect_dir(EnvironmentMap::uv_to_direction({0.25f, 0.5f}), V3f(1, 0, 0));
  expect_dir(EnvironmentMap::uv_to_direction({0.75f, 0.5f}), V3f(-1, 0, 0));
  expect_dir(EnvironmentMap::uv_to_direction({0.0f, 0.5f}), V3f(0, 0, -1));
  expect_dir(EnvironmentMap::uv_to_direction({0.3f, 0.f}), V3f(0, 1, 0));
  expect_dir(EnvironmentMap::uv_to_direction({0.3f, 1.f}), V3f(0, -1, 0));
  for (const Imath::V2f& uv : {Imath::V2f(0.1f, 0.2f), Imath::V2f(0.6f, 0.9f), Imath::V2f(0.95f, 0.45f)}) {
    const Imath::V2f back = EnvironmentMap::direction_to_uv(EnvironmentMap::uv_to_direction(uv));
    EXPECT_NEAR(back.x, uv.x, 1e-5f);
    EXPECT_NEAR(back.y, uv.y, 1e-5f);
  }
}

// A w x h map of `background` with one texel (bx, by) of `bright`.
std::shared_ptr<const EnvironmentMap> one_bright_texel(uint32_t w, uint32_t h, uint32_t bx, uint32_t by,
                                                       float bright, float background) {
  std::vector<C3f> t(size_t(w) * h, C3f(background));
  t[size_t(by) * w + bx] = C3f(bright, 0.5f * bright, 0.25f * bright);
  return std::make_shared<const EnvironmentMap>("test", w, h, std::move(t));
}

Light dome(std::shared_ptr<const EnvironmentMap> map, const C3f& radiance = C3f(1, 1, 1)) {
  Light l;
  l.prim_path = "/Dome";
  l.kind = LightKind::Dome;
  l.local_to_world.makeIdentity();
  l.radiance = radiance;
  l.environment = std::move(map);
  return l;
}

// Irradiance on a plane with unit normal n from the map (times scale), by
// integrating every texel on a sub-grid: the reference the estimators are
// checked against. With `squared`, the integral of (L cos)^2 instead.
C3f integrate_map(const EnvironmentMap& map, const V3f& n, const C3f& scale = C3f(1, 1, 1),
                  bool squared = false) {
  constexpr int kSub = 6;
  double sum[3] = {0, 0, 0};
  for (uint32_t y = 0; y < map.height(); ++y)
    for (uint32_t x = 0; x < map.width(); ++x)
      for (int j = 0; j < kSub; ++j)
        for (int i = 0; i < kSub; ++i) {
          const double u = (x + (i + 0.5) / kSub) / map.width(), v = (y + (j + 0.5) / kSub) / map.height();
          const V3f d = EnvironmentMap::uv_to_direction({float(u), float(v)});
          const double cos_n = n.dot(d);
          if (cos_n <= 0.0) continue;
          // d(omega) = sin(theta) dtheta dphi = 2 pi^2 sin(pi v) du dv.
          const double domega = 2 * kPiD * kPiD * std::sin(kPiD * v) / (double(map.width()) * map.height() * kSub * kSub);
          const C3f L = map.eval(d);
          for (int c = 0; c < 3; ++c) {
            const double f = L[c] * scale[c] * cos_n;
            sum[c] += (squared ? f * f : f) * domega;
          }
        }
  return C3f(float(sum[0]), float(sum[1]), float(sum[2]));
}

TEST(EnvironmentMap, PdfMatchesSamplesAndIntegratesToOne) {
  const auto map = one_bright_texel(32, 16, 5, 4, 100.f, 0.2f);
  Rng rng(7, 1);
  for (int k = 0; k < 200; ++k) {
    float pdf = 0.f;
    C3f value;
    const V3f d = map->sample(rng.uniform(), rng.uniform(), &pdf, &value);
    EXPECT_NEAR(d.length(), 1.f, 1e-5f);
    EXPECT_NEAR(map->pdf(d) / pdf, 1.f, 2e-3f);
    EXPECT_EQ(value, map->eval(d));
  }
  // The solid-angle density integrates to one over the sphere.
  double total = 0.0;
  const int nu = 256, nv = 128;
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      const double u = (i + 0.5) / nu, v = (j + 0.5) / nv;
      total += map->pdf(EnvironmentMap::uv_to_direction({float(u), float(v)})) * 2 * kPiD * kPiD *
               std::sin(kPiD * v) / (nu * nv);
    }
  EXPECT_NEAR(total, 1.0, 0.01);
}

TEST(EnvironmentMap, MeanIsSolidAngleWeighted) {
  // Bright top half (the +Y hemisphere), black bottom: mean = half.
  std::vector<C3f> t(16 * 8, C3f(0.f));
  for (size_t i = 0; i < 16 * 4; ++i) t[i] = C3f(2.f);
  const EnvironmentMap map("halves", 16, 8, std::move(t));
  EXPECT_NEAR(map.mean().x, 1.f, 1e-5f);
}

// The receiver: a large quad in y = 0 facing +Y (the dome's pole), and one
// with the same size in z = 0 facing +Z.
Scene open_plane(bool facing_z) {
  Scene scene;
  const uint32_t m = test::add_material(scene, C3f(0.5f, 0.5f, 0.5f));
  if (facing_z) {
    test::add_square_z(scene, 0.f, 0.f, 0.f, 10.f, m);
  } else {
    test::add_quad(scene, V3f(-10, 0, -10), V3f(-10, 0, 10), V3f(10, 0, 10), V3f(10, 0, -10), m);
  }
  return scene;
}

TEST(DomeLight, ConstantDomeGivesPiLOnAnOpenPlane) {
  Scene scene = open_plane(true);
  scene.lights.push_back(dome(nullptr, C3f(1.f, 2.f, 3.f)));
  const RayScene rays(scene);
  const C3f e = direct_irradiance(rays, V3f(0.3f, -0.2f, 0.f), V3f(0, 0, 1), 4096, 11);
  EXPECT_NEAR(e.x / float(kPiD), 1.f, 0.02f);
  EXPECT_NEAR(e.y / float(kPiD), 2.f, 0.04f);
  EXPECT_NEAR(e.z / float(kPiD), 3.f, 0.06f);
  // Under a roof, nothing arrives.
  const uint32_t m = 0;
  test::add_square_z(scene, 0.f, 0.f, 1.f, 10.f, m, /*down=*/true, "/roof");
  const RayScene covered(scene);
  const C3f e2 = direct_irradiance(covered, V3f(0.3f, -0.2f, 0.f), V3f(0, 0, 1), 1024, 11);
  // Only the grazing band below the roof's edge (1 unit up, 10 away) is open.
  EXPECT_LT(e2.x, 0.02f * float(kPiD));
}

TEST(DomeLight, MapIrradianceMatchesNumericalIntegration) {
  // A smooth sky plus a sun-like texel in the upper hemisphere.
  std::vector<C3f> t(64 * 32);
  for (uint32_t y = 0; y < 32; ++y)
    for (uint32_t x = 0; x < 64; ++x)
      t[y * 64 + x] = C3f(0.2f + 0.8f * float(y < 16) * (1.f - y / 16.f), 0.3f, 0.1f + 0.01f * float(x));
  t[6 * 64 + 20] = C3f(500.f, 450.f, 400.f);
  const auto map = std::make_shared<const EnvironmentMap>("sky", 64, 32, std::move(t));
  Scene scene = open_plane(false);
  scene.lights.push_back(dome(map, C3f(1.f, 1.f, 2.f)));
  const RayScene rays(scene);
  const C3f want = integrate_map(*map, V3f(0, 1, 0), C3f(1.f, 1.f, 2.f));
  const C3f got = direct_irradiance(rays, V3f(0.1f, 0.f, 0.2f), V3f(0, 1, 0), 4096, 3);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c] / want[c], 1.f, 0.02f) << c;

  // Rotating the dome by +90 degrees about X takes its pole to +Z: a plane
  // facing +Z then receives what the unrotated plane facing +Y did.
  Scene rotated = open_plane(true);
  Light l = dome(map, C3f(1.f, 1.f, 2.f));
  l.local_to_world = M44f(1, 0, 0, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 0, 0, 1);
  rotated.lights.push_back(l);
  const RayScene rotated_rays(rotated);
  const C3f got_rotated = direct_irradiance(rotated_rays, V3f(0.1f, 0.2f, 0.f), V3f(0, 0, 1), 4096, 3);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(got_rotated[c] / want[c], 1.f, 0.02f) << c;
}

// Per-sample irradiance estimates L cos / pdf on a plane facing +Y, from
// the dome's own sampling or from uniform directions over the sphere.
struct Moments {
  double mean = 0, variance = 0;
};
template <typename Sample>
Moments moments(int n, Sample sample) {
  double s = 0, s2 = 0;
  for (int k = 0; k < n; ++k) {
    const double x = sample(k);
    s += x;
    s2 += x * x;
  }
  Moments m;
  m.mean = s / n;
  m.variance = (s2 - s * s / n) / (n - 1);
  return m;
}

TEST(DomeLight, OneBrightTexelIsImportanceSampled) {
  // Nearly all the light comes from one texel of a 128 x 64 map.
  const auto map = one_bright_texel(128, 64, 40, 20, 2.0e4f, 0.01f);
  const Light light = dome(map);
  const V3f n(0, 1, 0);
  const double want = integrate_map(*map, n).x;
  Rng rng(5, 2);
  const int kN = 4000;
  const Moments importance = moments(kN, [&](int) {
    const LightSample s = sample_light(light, V3f(0, 0, 0), rng.uniform(), rng.uniform());
    const float c = n.dot(s.direction);
    return s.pdf > 0.f && c > 0.f ? double(s.radiance.x) * c / s.pdf : 0.0;
  });
  EXPECT_NEAR(importance.mean / want, 1.0, 0.02);
  // Uniform sampling of the sphere, X = 4 pi L cos+, hits the texel about
  // once in 6000 samples: its variance, 4 pi int (L cos+)^2 - E^2, computed
  // exactly from the map, is what importance sampling removes.
  const double uniform_variance = 4 * kPiD * integrate_map(*map, n, C3f(1, 1, 1), true).x - want * want;
  EXPECT_LT(importance.variance, 1e-3 * uniform_variance);
  // What remains: the cosine, and the rare background samples.
  EXPECT_LT(std::sqrt(importance.variance) / importance.mean, 0.2);
  // An empirical uniform estimate agrees with the exact variance's order.
  const Moments uniform = moments(200000, [&](int) {
    const float z = 1.f - 2.f * rng.uniform(), phi = 2.f * kPi * rng.uniform();
    const float r = std::sqrt(std::max(0.f, 1.f - z * z));
    const V3f d(r * std::cos(phi), r * std::sin(phi), z);
    const float c = n.dot(d);
    return c > 0.f ? double(dome_radiance(light, d).x) * c * 4.0 * kPiD : 0.0;
  });
  EXPECT_GT(uniform.variance, 1e3 * importance.variance);
}

TEST(DomeLight, EscapingRaysSeeTheDome) {
  const auto map = one_bright_texel(16, 8, 3, 2, 50.f, 1.f);
  Scene scene;
  scene.lights.push_back(dome(map, C3f(2.f, 2.f, 2.f)));
  scene.lights.push_back(dome(nullptr, C3f(0.5f, 0.5f, 0.5f)));
  const V3f d = EnvironmentMap::uv_to_direction({(3.5f) / 16.f, (2.5f) / 8.f});
  C3f radiance;
  float t = 0.f, pdf = 0.f;
  ASSERT_TRUE(intersect_light(scene.lights[0], V3f(1, 2, 3), d, std::numeric_limits<float>::infinity(),
                              &radiance, &t, &pdf));
  EXPECT_TRUE(std::isinf(t));
  EXPECT_NEAR(radiance.x, 100.f, 1e-3f);
  EXPECT_NEAR(pdf, map->pdf(d), 1e-6f * pdf);
  // A surface in the way hides it.
  EXPECT_FALSE(intersect_light(scene.lights[0], V3f(1, 2, 3), d, 10.f, &radiance, &t, &pdf));
  EXPECT_NEAR(environment_radiance(scene, d).x, 100.5f, 1e-3f);
  // Sampling and evaluation agree on radiance and density.
  Rng rng(3, 3);
  for (int k = 0; k < 50; ++k) {
    const LightSample s = sample_light(scene.lights[0], V3f(0, 0, 0), rng.uniform(), rng.uniform());
    float p2 = 0.f;
    const C3f l2 = dome_radiance(scene.lights[0], s.direction, &p2);
    EXPECT_NEAR(p2 / s.pdf, 1.f, 2e-3f);
    EXPECT_NEAR(l2.x, s.radiance.x, 1e-4f * s.radiance.x);
    EXPECT_TRUE(std::isinf(s.distance));
    EXPECT_FALSE(s.delta);
  }
  // Power: pi times the mean radiance (W/m^2, as for distant lights).
  EXPECT_NEAR(light_power(scene.lights[1]), kPi * 0.5f, 1e-5f);
  EXPECT_NEAR(light_power(scene.lights[0]), kPi * 2.f * (map->mean().x + map->mean().y + map->mean().z) / 3.f, 1e-4f);
}

}  // namespace
}  // namespace pbgi
