// The irradiance cache's criteria (irradiance_cache.h) and the validity
// distance the gather reports (Gatherer::harmonic_mean_distance).
#include "server/gather/irradiance_cache.h"

#include "common/errors.h"
#include "surfel_shapes.h"
#include "surfel_tree.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

namespace pbgi {
namespace {

using Imath::C3f;
using Imath::V3f;

IrradianceRecord record_at(const V3f& p, const V3f& n, float radius, float irradiance, float ao = 0.5f) {
  IrradianceRecord r;
  r.position = p;
  r.normal = n;
  r.radius = radius;
  r.result.irradiance = C3f(irradiance);
  r.result.ao = ao;
  r.result.glossy = C3f(7.f);  // never carried over: it depends on the view
  r.result.bent_normal = n;
  return r;
}

TEST(IrradianceCache, RecordReachesTolerenceTimesItsRadiusOnItsPlane) {
  const IrradianceRecord r = record_at(V3f(0), V3f(0, 0, 1), 2.f, 1.f);
  // eps = distance / R on the plane.
  EXPECT_NEAR(*ward_error(r, V3f(0.1f, 0, 0), V3f(0, 0, 1)), 0.05f, 1e-6f);
  EXPECT_NEAR(*ward_error(r, V3f(0, -0.4f, 0), V3f(0, 0, 1)), 0.2f, 1e-6f);
  IrradianceCache cache(0.1f);
  cache.add(r);
  cache.build();
  EXPECT_TRUE(cache.interpolate(V3f(0.19f, 0, 0), V3f(0, 0, 1)));
  EXPECT_FALSE(cache.interpolate(V3f(0.21f, 0, 0), V3f(0, 0, 1)));
  EXPECT_FALSE(cache.interpolate(V3f(0, 0.21f, 0), V3f(0, 0, 1)));
}

TEST(IrradianceCache, NeverAcrossANormalEdge) {
  // A crease: floor record, wall receiver at the same place.
  const IrradianceRecord r = record_at(V3f(0), V3f(0, 0, 1), 100.f, 1.f);
  EXPECT_FALSE(ward_error(r, V3f(0.01f, 0, 0.01f), V3f(1, 0, 0)));
  // Within 18 degrees the normal term counts: sqrt(1 - cos 10deg) = 0.12.
  const V3f tilted(std::sin(0.1745f), 0, std::cos(0.1745f));
  ASSERT_TRUE(ward_error(r, V3f(0), tilted));
  EXPECT_NEAR(*ward_error(r, V3f(0), tilted), 0.1234f, 1e-3f);
  IrradianceCache cache(0.1f);
  cache.add(r);
  cache.build();
  EXPECT_FALSE(cache.interpolate(V3f(0), tilted)) << "0.12 > tolerance 0.1";
  EXPECT_FALSE(cache.interpolate(V3f(0.001f, 0, 0), V3f(-1, 0, 0))) << "a back face";
}

TEST(IrradianceCache, NeverAcrossADepthStep) {
  // A box face 2 cm in front of a wall, both facing +z: same normal, but
  // the wall point is off the face's tangent plane.
  const IrradianceRecord face = record_at(V3f(0, 0, 0.02f), V3f(0, 0, 1), 100.f, 1.f);
  EXPECT_FALSE(ward_error(face, V3f(0.1f, 0, 0), V3f(0, 0, 1)));
  EXPECT_TRUE(ward_error(face, V3f(0.1f, 0, 0.02f), V3f(0, 0, 1)));
  // A slope of 1 in 100 (a gently curved or tessellated surface) passes.
  EXPECT_TRUE(ward_error(face, V3f(1.f, 0, 0.03f), V3f(0, 0, 1)));
}

TEST(IrradianceCache, MixesValidRecordsByWardWeightsWithoutGlossy) {
  IrradianceCache cache(0.2f);
  cache.add(record_at(V3f(0, 0, 0), V3f(0, 0, 1), 1.f, 1.f, 0.2f));
  cache.add(record_at(V3f(0.1f, 0, 0), V3f(0, 0, 1), 1.f, 3.f, 0.6f));
  cache.add(record_at(V3f(0.05f, 0, 0.5f), V3f(0, 0, 1), 1.f, 100.f));  // above: a depth step
  EXPECT_FALSE(cache.interpolate(V3f(0), V3f(0, 0, 1))) << "nothing indexed before build()";
  cache.build();
  // Half way: equal weights.
  const std::optional<GatherResult> mid = cache.interpolate(V3f(0.05f, 0, 0), V3f(0, 0, 1));
  ASSERT_TRUE(mid);
  EXPECT_NEAR(mid->irradiance.x, 2.f, 1e-5f);
  EXPECT_NEAR(mid->ao, 0.4f, 1e-6f);
  EXPECT_EQ(mid->glossy.x, 0.f);
  EXPECT_NEAR(mid->bent_normal.z, 1.f, 1e-6f);
  // Closer to the first: more of it; on it: (almost) only it.
  const std::optional<GatherResult> near0 = cache.interpolate(V3f(0.02f, 0, 0), V3f(0, 0, 1));
  ASSERT_TRUE(near0);
  EXPECT_LT(near0->irradiance.x, 1.5f);
  const std::optional<GatherResult> on0 = cache.interpolate(V3f(0), V3f(0, 0, 1));
  ASSERT_TRUE(on0);
  EXPECT_NEAR(on0->irradiance.x, 1.f, 3e-3f);
}

TEST(IrradianceCache, IndexFindsWhatAScanFinds) {
  // Many records of random radii: the index must not miss a valid one.
  IrradianceCache cache(0.3f);
  std::vector<IrradianceRecord> all;
  uint32_t seed = 12345;
  auto rnd = [&seed] {
    seed = seed * 1664525u + 1013904223u;
    return float(seed >> 8) / float(1u << 24);
  };
  for (int i = 0; i < 500; ++i) {
    all.push_back(record_at(V3f(10 * rnd(), 10 * rnd(), 0), V3f(0, 0, 1), 0.1f + 3 * rnd(), rnd()));
    cache.add(all.back());
  }
  cache.build();
  for (int q = 0; q < 200; ++q) {
    const V3f p(10 * rnd(), 10 * rnd(), 0);
    bool any = false;
    for (const IrradianceRecord& r : all) any = any || *ward_error(r, p, V3f(0, 0, 1)) < 0.3f;
    EXPECT_EQ(bool(cache.interpolate(p, V3f(0, 0, 1))), any) << "query " << q;
  }
}

TEST(IrradianceCache, RefusesBadTolerance) {
  EXPECT_THROW(IrradianceCache(0.f), InvalidArgument);
  EXPECT_THROW(IrradianceCache(-0.1f), InvalidArgument);
  EXPECT_THROW(IrradianceCache(std::numeric_limits<float>::quiet_NaN()), InvalidArgument);
  EXPECT_THROW(IrradianceCache(1.5f), InvalidArgument);
}

// The validity distance of a gather: the harmonic mean distance of what
// it saw. Under a large plane at height h the exact value is 1.5 h (the
// cosine-weighted harmonic mean of h / cos); the gather's is a little
// shorter (a node's fragment starts at its nearest depth), and
// proportional to h. Near a wall it shrinks towards the wall's distance;
// with nothing in view it is infinite.
TEST(HarmonicMeanDistance, FollowsTheNearestGeometry) {
  float per_h[2];
  for (const int i : {0, 1}) {
    const float h = i == 0 ? 0.5f : 1.f;
    std::vector<Surfel> s;
    test::add_quad(s, V3f(-30 * h, -30 * h, h), V3f(60 * h, 0, 0), V3f(0, 60 * h, 0), 300, 300, C3f(1),
                   /*flip=*/true);
    test::SurfelTree tree(std::move(s));
    Gatherer g(tree, GatherOptions{});
    g.gather({V3f(0), V3f(0, 0, 1)});
    per_h[i] = g.harmonic_mean_distance() / h;
    EXPECT_GT(per_h[i], 1.f) << "h " << h;
    EXPECT_LE(per_h[i], 1.5f) << "h " << h;
  }
  EXPECT_NEAR(per_h[0], per_h[1], 0.02f * per_h[1]);
  // A floor with a wall at x = 1: the distance shrinks as the receiver
  // nears the wall.
  std::vector<Surfel> s;
  test::add_quad(s, V3f(1, -5, 0), V3f(0, 10, 0), V3f(0, 0, 5), 200, 100, C3f(1), /*flip=*/true);
  test::SurfelTree tree(std::move(s));
  Gatherer g(tree, GatherOptions{});
  float last = std::numeric_limits<float>::infinity();
  for (const float x : {-2.f, 0.f, 0.5f, 0.9f}) {
    g.gather({V3f(x, 0, 0), V3f(0, 0, 1)});
    const float r = g.harmonic_mean_distance();
    EXPECT_LT(r, last) << "x " << x;
    EXPECT_LT(r, 3.f * (1.f - x)) << "x " << x;
    last = r;
  }
  test::SurfelTree empty({});
  Gatherer e(empty, GatherOptions{});
  e.gather({V3f(0), V3f(0, 0, 1)});
  EXPECT_EQ(e.harmonic_mean_distance(), std::numeric_limits<float>::infinity());
}

}  // namespace
}  // namespace pbgi
