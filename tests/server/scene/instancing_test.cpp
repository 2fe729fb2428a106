// Scene prototypes + instances against the same geometry flattened: triangle
// ids, world-space accessors, ray hits (Embree instances), emitter sampling
// and the geometry's memory.
#include "tests/server/scene/instanced_scenes.h"

#include "common/errors.h"
#include "server/reference/emissive_triangles.h"
#include "server/scene/ray_scene.h"
#include "server/scene/scene_validation.h"
#include "server/scene/surface_colors.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace pbgi {
namespace {

using namespace pbgi::test;

void expect_near(const V3f& a, const V3f& b, float tol, const std::string& what) {
  EXPECT_NEAR(a.x, b.x, tol) << what;
  EXPECT_NEAR(a.y, b.y, tol) << what;
  EXPECT_NEAR(a.z, b.z, tol) << what;
}

TEST(Instancing, TriangleIdsNumberWorldThenInstancesInWorldSpace) {
  const Scene inst = instanced_scene();
  const Scene flat = flattened_scene();
  validate_scene(inst);
  ASSERT_EQ(inst.triangle_count(), flat.triangle_count());
  ASSERT_EQ(inst.mesh_count(), flat.mesh_count());
  // The flattened scene appends instances in order too: the ids coincide.
  for (uint32_t id = 0; id < inst.triangle_count(); ++id) {
    const TriangleRef a = inst.triangle(id), b = flat.triangle(id);
    EXPECT_EQ(a.instance != nullptr, id >= 1u);
    for (int k = 0; k < 3; ++k) {
      expect_near(a.position(k), b.position(k), 1e-5f, "triangle " + std::to_string(id));
      expect_near(a.normal(k).normalized(), b.normal(k).normalized(), 1e-5f, "normal " + std::to_string(id));
    }
    EXPECT_EQ(a.material(), b.material());
    EXPECT_EQ(a.double_sided(), b.double_sided());
    EXPECT_EQ(inst.mesh_ordinal(id), flat.mesh_ordinal(id)) << id;
  }
  const Box3f bi = inst.bounds(), bf = flat.bounds();
  expect_near(bi.min, bf.min, 1e-5f, "bounds min");
  expect_near(bi.max, bf.max, 1e-5f, "bounds max");
}

TEST(Instancing, RayHitsMatchTheFlattenedScene) {
  const Scene inst = instanced_scene();
  const Scene flat = flattened_scene();
  const RayScene ri(inst), rf(flat);
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  int hits = 0;
  for (int i = 0; i < 4000; ++i) {
    const V3f origin(8.f * u(rng), 8.f * u(rng), 8.f * u(rng));
    const V3f dir = V3f(u(rng), u(rng), u(rng)).normalized();
    const Hit a = ri.intersect(origin, dir), b = rf.intersect(origin, dir);
    ASSERT_EQ(a.valid(), b.valid()) << "ray " << i;
    if (!a.valid()) continue;
    ++hits;
    EXPECT_NEAR(a.t, b.t, 1e-4f * std::max(1.f, b.t)) << "ray " << i;
    EXPECT_EQ(a.triangle, b.triangle) << "ray " << i;
    expect_near(a.geometric_normal, b.geometric_normal, 1e-4f, "ng, ray " + std::to_string(i));
    expect_near(ri.shading_normal(a), rf.shading_normal(b), 1e-4f, "ns, ray " + std::to_string(i));
    // Barycentrics refer to the same (re-wound) corners.
    expect_near(ri.hit_point(a).p, rf.hit_point(b).p, 1e-4f, "point, ray " + std::to_string(i));
    EXPECT_EQ(ri.occluded(origin, dir, 0.f, b.t * 1.01f), true);
  }
  EXPECT_GT(hits, 200);  // the test is not vacuous
}

TEST(Instancing, EmittersOfInstancesAreSampledLikeFlattenedOnes) {
  const Scene inst = instanced_scene();
  const Scene flat = flattened_scene();
  const EmissiveTriangles ei(inst), ef(flat);
  ASSERT_EQ(ei.size(), placements().size());  // the tilted triangle of each instance
  ASSERT_EQ(ei.size(), ef.size());
  for (uint32_t id = 0; id < inst.triangle_count(); ++id) EXPECT_NEAR(ei.pdf_area(id), ef.pdf_area(id), 1e-6f) << id;
  const EmitterSample a = ei.sample(0.6f, 0.3f, 0.8f), b = ef.sample(0.6f, 0.3f, 0.8f);
  EXPECT_EQ(a.triangle, b.triangle);
  expect_near(a.point.p, b.point.p, 1e-5f, "emitter point");
  expect_near(a.normal, b.normal, 1e-5f, "emitter normal");
  EXPECT_EQ(surface_colors(inst, a.triangle, a.b1, a.b2).emission, inst.materials[1].emission);
}

TEST(Instancing, GeometryMemoryDoesNotGrowWithInstancesBeyondTransforms) {
  auto scene_with = [](size_t n) {
    Scene s = base_scene();
    s.prototypes.push_back({"/Proto", prototype_soup()});
    s.instances.reserve(n);  // exact capacity: the byte count is exact
    for (size_t i = 0; i < n; ++i) s.add_instance(0, placement(0.01f * float(i), V3f(1.f), V3f(float(i), 0, 0)));
    return s;
  };
  const Scene few = scene_with(10), many = scene_with(10000);
  EXPECT_EQ(many.triangle_count(), 1u + 10000u * 3u);
  EXPECT_EQ(many.geometry_bytes() - few.geometry_bytes(), (10000u - 10u) * sizeof(Instance));
  // A transform and its normal matrix, the numbering and a flag: far below
  // one copy of even this 3-triangle prototype's arrays per instance would cost.
  EXPECT_LE(sizeof(Instance), 160u);
  const RayScene rays(many);  // one BVH for the prototype, 10000 instances of it
  const Hit h = rays.intersect(V3f(5000.3f, 0.2f, 5.f), V3f(0, 0, -1));
  ASSERT_TRUE(h.valid());
  EXPECT_EQ(many.triangle(h.triangle).instance, &many.instances[5000]);
}

TEST(Instancing, ValidationRefusesAPrototypeGrownAfterItsInstances) {
  Scene s = instanced_scene();
  s.prototypes[0].triangles.indices.insert(s.prototypes[0].triangles.indices.end(), {0, 1, 2});
  s.prototypes[0].triangles.material.push_back(0);
  s.prototypes[0].triangles.mesh.push_back(0);
  EXPECT_THROW(validate_scene(s), SceneError);
  Scene bad = base_scene();
  EXPECT_THROW(bad.add_instance(0, M44f()), SceneError);  // no such prototype
  bad.prototypes.push_back({"/Proto", prototype_soup()});
  M44f singular;
  singular.setScale(V3f(1.f, 0.f, 1.f));
  EXPECT_THROW(bad.add_instance(0, singular), SceneError);
}

}  // namespace
}  // namespace pbgi
