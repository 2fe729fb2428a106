// Surfels of instanced geometry: every instance is its own surface (its own
// surfels, lit where it stands), sampled by transforming the prototype's
// triangles on the fly -- the same surfels as the scene flattened.
#include "server/scene/ray_scene.h"
#include "server/surfels/surfels.h"
#include "tests/server/scene/instanced_scenes.h"

#include <gtest/gtest.h>

#include <cmath>

namespace pbgi {
namespace {

void expect_same_surfels(const std::vector<Surfel>& a, const std::vector<Surfel>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_NEAR((a[i].position - b[i].position).length(), 0.f, 1e-5f) << i;
    EXPECT_NEAR((a[i].normal - b[i].normal).length(), 0.f, 1e-5f) << i;
    EXPECT_NEAR(a[i].radius, b[i].radius, 1e-6f * std::max(1.f, b[i].radius)) << i;
    EXPECT_EQ(a[i].emission, b[i].emission) << i;
    EXPECT_NEAR(a[i].radiance.x, b[i].radiance.x, 1e-4f * std::max(1.f, b[i].radiance.x)) << i;
  }
}

class InstancedSurfels : public ::testing::TestWithParam<SurfelSampler> {};

TEST_P(InstancedSurfels, EqualTheFlattenedScenesSurfels) {
  const Scene inst = test::instanced_scene();
  const Scene flat = test::flattened_scene();
  SurfelOptions o;
  o.sampler = GetParam();
  o.spacing = 0.1f;
  std::vector<Surfel> a = sample_surfels(inst, o), b = sample_surfels(flat, o);
  ASSERT_GT(a.size(), 500u);
  // Instances' surfels really are spread over the placements (one prototype
  // copy would put them all inside the unit cube around the origin).
  size_t outside = 0;
  for (const Surfel& s : a) outside += std::fabs(s.position.x) > 2.f || std::fabs(s.position.z) > 2.f;
  EXPECT_GT(outside, a.size() / 3);
  expect_same_surfels(a, b);
  // Lit the same way: a distant light over everything.
  auto lit = [](Scene s) {
    Light sun;
    sun.kind = LightKind::Distant;
    sun.radiance = C3f(3.f);
    sun.local_to_world.setAxisAngle(V3f(1, 0, 0), -1.f);
    s.lights.push_back(sun);
    return s;
  };
  const Scene li = lit(inst), lf = lit(flat);
  const RayScene ri(li), rf(lf);
  shade_direct(ri, o, a);
  shade_direct(rf, o, b);
  expect_same_surfels(a, b);
}

INSTANTIATE_TEST_SUITE_P(Samplers, InstancedSurfels,
                         ::testing::Values(SurfelSampler::kUniform, SurfelSampler::kPoisson));

}  // namespace
}  // namespace pbgi
