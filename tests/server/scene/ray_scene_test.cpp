#include "server/scene/ray_scene.h"
#include "common/errors.h"
#include "server/scene/scene_validation.h"
#include "tests/server/scene/test_scenes.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

namespace pbgi {
namespace {

Scene unit_quad_scene() {
  Scene s;
  s.source_path = "quad.usda";
  const uint32_t m = test::add_material(s, {0.5f, 0.5f, 0.5f});
  test::add_square_z(s, 0.f, 0.f, 0.f, 1.f, m);  // [-1,1]^2 at z = 0, normal +Z
  return s;
}

TEST(RayScene, QuadHitAndMiss) {
  const Scene s = unit_quad_scene();
  const RayScene rays(s);
  const Hit hit = rays.intersect(V3f(0.25f, -0.5f, 2.f), V3f(0, 0, -1));
  ASSERT_TRUE(hit.valid());
  EXPECT_NEAR(hit.t, 2.f, 1e-5f);
  ASSERT_LT(hit.triangle, 2u);
  // The barycentrics reproduce the hit point.
  const TriangleSoup& t = s.triangles;
  const uint32_t* idx = &t.indices[3 * hit.triangle];
  const V3f p = (1 - hit.u - hit.v) * t.positions[idx[0]] + hit.u * t.positions[idx[1]] +
                hit.v * t.positions[idx[2]];
  EXPECT_NEAR(p.x, 0.25f, 1e-5f);
  EXPECT_NEAR(p.y, -0.5f, 1e-5f);

  EXPECT_FALSE(rays.intersect(V3f(1.5f, 0.f, 2.f), V3f(0, 0, -1)).valid());   // beside
  EXPECT_FALSE(rays.intersect(V3f(0.f, 0.f, 2.f), V3f(0, 0, 1)).valid());     // away
  EXPECT_FALSE(rays.intersect(V3f(0.f, 0.f, 2.f), V3f(0, 0, -1), 0.f, 1.9f).valid());  // tmax
  EXPECT_FALSE(rays.intersect(V3f(0.f, 0.f, 2.f), V3f(0, 0, -1), 2.1f).valid());       // tmin
}

TEST(RayScene, HitsFromBothSides) {
  const Scene s = unit_quad_scene();
  const RayScene rays(s);
  const Hit below = rays.intersect(V3f(0.f, 0.f, -3.f), V3f(0, 0, 1));
  ASSERT_TRUE(below.valid());
  EXPECT_NEAR(below.t, 3.f, 1e-5f);
}

TEST(RayScene, OcclusionRespectsInterval) {
  const Scene s = unit_quad_scene();
  const RayScene rays(s);
  EXPECT_TRUE(rays.occluded(V3f(0, 0, 1), V3f(0, 0, -1), 0.f, 2.f));
  EXPECT_FALSE(rays.occluded(V3f(0, 0, 1), V3f(0, 0, -1), 0.f, 0.99f));
  EXPECT_FALSE(rays.occluded(V3f(0, 0, 1), V3f(0, 0, -1), 1.01f, 2.f));
  EXPECT_FALSE(rays.occluded(V3f(3, 0, 1), V3f(0, 0, -1), 0.f, 2.f));
}

TEST(RayScene, GeometricNormalFollowsWindingNotRay) {
  Scene s;
  const uint32_t m = test::add_material(s, {0.5f, 0.5f, 0.5f});
  test::add_square_z(s, 0.f, 0.f, 0.f, 1.f, m, /*down=*/false);
  test::add_square_z(s, 5.f, 0.f, 0.f, 1.f, m, /*down=*/true);
  const RayScene rays(s);
  for (const float dz : {-1.f, 1.f}) {
    const Hit up = rays.intersect(V3f(0, 0, -2 * dz), V3f(0, 0, dz));
    const Hit down = rays.intersect(V3f(5, 0, -2 * dz), V3f(0, 0, dz));
    ASSERT_TRUE(up.valid() && down.valid());
    EXPECT_NEAR(up.geometric_normal.z, 1.f, 1e-6f);
    EXPECT_NEAR(down.geometric_normal.z, -1.f, 1e-6f);
    // Without vertex normals the shading normal is the geometric one.
    EXPECT_NEAR(rays.shading_normal(up).z, 1.f, 1e-6f);
  }
}

TEST(RayScene, ShadingNormalInterpolatesVertexNormals) {
  Scene s = unit_quad_scene();
  // Normals tilted toward +X on the right edge, -X on the left edge.
  const float k = 0.6f;
  for (const V3f& p : s.triangles.positions) {
    s.triangles.normals.push_back(V3f(p.x > 0 ? k : -k, 0.f, 0.8f));
  }
  const RayScene rays(s);
  const Hit mid = rays.intersect(V3f(0, 0.3f, 1), V3f(0, 0, -1));
  ASSERT_TRUE(mid.valid());
  const V3f n_mid = rays.shading_normal(mid);
  EXPECT_NEAR(n_mid.x, 0.f, 1e-5f);
  EXPECT_NEAR(n_mid.z, 1.f, 1e-5f);
  const Hit right = rays.intersect(V3f(0.5f, 0.3f, 1), V3f(0, 0, -1));
  const V3f n_right = rays.shading_normal(right);
  EXPECT_NEAR(n_right.length(), 1.f, 1e-5f);
  // At x = 0.5 the interpolated normal is (0.75*0.6 - 0.25*0.6, 0, 0.8) = (0.3, 0, 0.8).
  EXPECT_NEAR(n_right.x / n_right.z, 0.3f / 0.8f, 1e-4f);
  // The geometric normal is untouched by vertex normals.
  EXPECT_NEAR(right.geometric_normal.z, 1.f, 1e-6f);
}

// Two coincident squares facing opposite ways (a box's bottom on a floor):
// a filter that accepts only one finds it whichever of the two Embree meets
// first (that order differs between ISAs; this test runs under two).
TEST(RayScene, FilteredHitFindsTheAcceptedOfTwoCoincidentSurfaces) {
  Scene s;
  const uint32_t m = test::add_material(s, {0.5f, 0.5f, 0.5f});
  const uint32_t up = test::add_square_z(s, 0.f, 0.f, 0.f, 1.f, m, false, "/floor");
  const uint32_t down = test::add_square_z(s, 0.f, 0.f, 0.f, 1.f, m, true, "/box_bottom");
  const RayScene rays(s);
  for (const float sign : {1.f, -1.f}) {
    const V3f wanted_normal(0.f, 0.f, sign);  // accept only triangles facing this way
    size_t calls = 0;
    for (int i = 0; i < 64; ++i) {
      const V3f origin(-0.9f + 0.028f * float(i), 0.37f - 0.011f * float(i), -1.f);
      const Hit hit = rays.intersect(origin, V3f(0, 0, 1), 0.f, 2.f, [&](const Hit& h) {
        ++calls;
        return h.geometric_normal.dot(wanted_normal) > 0.5f;
      });
      ASSERT_TRUE(hit.valid()) << i;
      EXPECT_NEAR(hit.t, 1.f, 1e-6f);
      EXPECT_EQ(s.triangles.mesh[hit.triangle], sign > 0.f ? up : down) << i;
      EXPECT_EQ(hit.geometric_normal, wanted_normal) << i;
    }
    EXPECT_GE(calls, 64u);
  }
  // A filter that rejects everything finds nothing; one that accepts
  // everything finds one of the two at the unfiltered distance.
  EXPECT_FALSE(rays.intersect(V3f(0.1f, 0.2f, -1.f), V3f(0, 0, 1), 0.f, 2.f, [](const Hit&) { return false; })
                   .valid());
  const Hit plain = rays.intersect(V3f(0.1f, 0.2f, -1.f), V3f(0, 0, 1));
  const Hit all = rays.intersect(V3f(0.1f, 0.2f, -1.f), V3f(0, 0, 1), 0.f, 1e30f, [](const Hit&) { return true; });
  ASSERT_TRUE(all.valid());
  EXPECT_EQ(all.t, plain.t);
}

// A device limited to SSE4.2 (what every x86-64 CPU the tests run on has)
// builds and traces: the configuration string is well formed.
TEST(RayScene, DeviceConfigurationReachesEmbree) {
  const Scene s = unit_quad_scene();
  const std::string saved = embree_device_config();
  set_embree_device_config("isa=sse4.2");
  {
    const RayScene rays(s);
    EXPECT_TRUE(rays.intersect(V3f(0.25f, -0.5f, 2.f), V3f(0, 0, -1)).valid());
  }
  set_embree_device_config(saved);
}

TEST(RayScene, EmptySceneMisses) {
  Scene s;
  const RayScene rays(s);
  EXPECT_FALSE(rays.intersect(V3f(0, 0, 0), V3f(0, 0, 1)).valid());
  EXPECT_FALSE(rays.occluded(V3f(0, 0, 0), V3f(0, 0, 1), 0.f, 1e30f));
  EXPECT_GT(rays.ray_epsilon(), 0.f);
}

TEST(RayScene, EpsilonScalesWithScene) {
  Scene small, large;
  const uint32_t m1 = test::add_material(small, {1, 1, 1});
  const uint32_t m2 = test::add_material(large, {1, 1, 1});
  test::add_square_z(small, 0, 0, 0, 1.f, m1);
  test::add_square_z(large, 0, 0, 0, 1000.f, m2);
  const RayScene a(small), b(large);
  EXPECT_NEAR(b.ray_epsilon() / a.ray_epsilon(), 1000.f, 10.f);
  EXPECT_LT(b.ray_epsilon(), 1.f);  // well below the scene's features
}

// Far from the origin (1e5: floats 0.008 apart) secondary rays must clear
// the surface they leave without skipping geometry a few centimetres away.
// The old global epsilon (32 ulps of the largest coordinate, 0.38 here)
// started them above the second quad, 0.05 away.
TEST(RayScene, SpawnedRaysClearTheSurfaceFarFromTheOrigin) {
  for (const float base : {0.f, 1e3f, 1e5f}) {
    SCOPED_TRACE(base);
    Scene s;
    const uint32_t m = test::add_material(s, {0.5f, 0.5f, 0.5f});
    // A tilted 2 x 2 quad (normal ~(0.2, 0.3, 0.93)) and a copy 0.05 above it
    // facing it, both around (base, base, base).
    const V3f o(base, base, base), n = V3f(0.2f, 0.3f, 0.93f).normalized();
    const V3f e1 = V3f(1, 0, 0).cross(n).normalized(), e2 = n.cross(e1);
    const V3f a = o - e1 - e2, b = o + e1 - e2, c = o + e1 + e2, d = o - e1 + e2;
    test::add_quad(s, a, b, c, d, m, "/lower");
    const V3f up = 0.05f * n;
    test::add_quad(s, a + up, d + up, c + up, b + up, m, "/upper");
    const RayScene rays(s);
    EXPECT_LT(rays.ray_epsilon(), 1e-6f * base + 1e-5f);

    uint64_t state = 12345;
    auto uniform = [&state] {
      state = state * 6364136223846793005ull + 1442695040888963407ull;
      return float(state >> 40) * 0x1p-24f;
    };
    int hits_lower = 0, hits_upper = 0, escaped = 0;
    float worst_offset = 0.f;
    for (int i = 0; i < 2000; ++i) {
      // A ray from far above onto the lower quad, between the quads' edges.
      const V3f target = o + (1.4f * uniform() - 0.7f) * e1 + (1.4f * uniform() - 0.7f) * e2;
      const V3f from = o + 0.02f * n + (target - o);  // between the quads
      const Hit hit = rays.intersect(from, (target - from).normalized());
      ASSERT_TRUE(hit.valid());
      ASSERT_LT(hit.triangle, 2u) << "the first ray hit the upper quad";
      const SurfacePoint sp = rays.hit_point(hit);
      const V3f ng = hit.geometric_normal.dot(n) > 0.f ? hit.geometric_normal : -hit.geometric_normal;
      // A direction in the upper hemisphere, down to 12 degrees of grazing.
      const float phi = 6.2831853f * uniform(), cos_t = 0.2f + 0.8f * uniform();
      const float sin_t = std::sqrt(1.f - cos_t * cos_t);
      const V3f w = (cos_t * ng + sin_t * std::cos(phi) * e1 + sin_t * std::sin(phi) * e2).normalized();
      const V3f origin = RayScene::offset_ray_origin(sp, ng, w);
      worst_offset = std::max(worst_offset, (origin - sp.p).dot(ng));
      const Hit next = rays.intersect(origin, w);
      if (!next.valid()) ++escaped;
      else if (next.triangle < 2) ++hits_lower;
      else ++hits_upper;
    }
    EXPECT_EQ(hits_lower, 0) << "self-intersections";
    // Everything leaving the centre region upward within 78 degrees of the
    // normal meets the upper quad before its edge (0.7 + 0.05 tan 78 < 1).
    EXPECT_EQ(hits_upper, 2000);
    EXPECT_EQ(escaped, 0);
    // The offset is a few ulps of the point's coordinates.
    EXPECT_LT(worst_offset, 4e-7f * base + 1e-5f);
    EXPECT_GT(worst_offset, 0.f);
  }
}

TEST(RayScene, RejectsOutOfRangeIndicesNamingTheMesh) {
  Scene s = unit_quad_scene();
  s.triangles.indices[4] = 99;
  try {
    RayScene rays(s);
    FAIL() << "expected SceneError";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("quad.usda"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("/square"), std::string::npos) << e.what();
  }
  Scene bad_material = unit_quad_scene();
  bad_material.triangles.material[1] = 7;
  EXPECT_THROW(validate_scene(bad_material), SceneError);
  Scene bad_normals = unit_quad_scene();
  bad_normals.triangles.normals.resize(1);
  EXPECT_THROW(validate_scene(bad_normals), SceneError);
}

TEST(Scene, BoundsAndCameras) {
  Scene s = unit_quad_scene();
  s.triangles.positions.push_back(V3f(NAN, 0, 0));  // ignored, not propagated
  const Box3f b = s.bounds();
  EXPECT_EQ(b.min, V3f(-1, -1, 0));
  EXPECT_EQ(b.max, V3f(1, 1, 0));
  EXPECT_TRUE(Scene().bounds().isEmpty());

  Camera cam;
  cam.prim_path = "/cam";
  cam.focal_length = 35.f;
  s.cameras["/cam"] = cam;
  ASSERT_NE(s.find_camera("/cam"), nullptr);
  EXPECT_EQ(s.find_camera("/cam")->focal_length, 35.f);
  EXPECT_EQ(s.find_camera("/other"), nullptr);
}

}  // namespace
}  // namespace pbgi
