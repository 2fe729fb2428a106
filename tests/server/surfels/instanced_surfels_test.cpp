// Surfels of instanced geometry: every instance is its own surface (its own
// surfels, lit where it stands), sampled by transforming the prototype's
// triangles on the fly -- the same surfels as the scene flattened.
#include "server/scene/ray_scene.h"
#include "server/surfels/surfels.h"
#include "tests/server/scene/instanced_scenes.h"

#include <gtest/gtest.h>

#include <cmath>
#include <utility>

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

// 40 placements of the test prototype under non-uniform scales (a third
// of them mirrored) over the world triangle: instanced, and flattened into
// the world soup with the same triangle ids.
std::pair<Scene, Scene> forty_instances() {
  Scene inst = test::base_scene();
  inst.prototypes.push_back({"/Proto", test::prototype_soup()});
  std::vector<M44f> placed;
  for (int k = 0; k < 40; ++k) {
    const float a = 0.37f * float(k);
    const V3f scale(0.5f + 0.05f * float(k % 7), 1.5f - 0.1f * float(k % 5), k % 3 == 0 ? -1.f : 0.8f);
    placed.push_back(test::placement(a, scale, V3f(3.f * float(k % 8), float(k / 8), -3.f * float(k / 8))));
    inst.add_instance(0, placed.back());
  }
  Scene flat = test::base_scene();
  test::flatten_into(flat, test::prototype_soup(), placed);
  return {std::move(inst), std::move(flat)};
}

// Many instances under non-uniform scales, the spacing derived from
// target_surfels (so from the total area, summed instance by instance):
// the same count and area per unit area as the scene flattened.
TEST_P(InstancedSurfels, SameDensityPerUnitAreaAsTheFlattenedScene) {
  const auto [inst, flat] = forty_instances();
  SurfelOptions o;
  o.sampler = GetParam();
  o.target_surfels = 20000;
  const std::vector<Surfel> a = sample_surfels(inst, o), b = sample_surfels(flat, o);
  double area_a = 0, area_b = 0;
  for (const Surfel& s : a) area_a += s.area();
  for (const Surfel& s : b) area_b += s.area();
  ASSERT_GT(b.size(), 10000u);
  EXPECT_NEAR(double(a.size()) / double(b.size()), 1.0, 1e-3) << a.size() << " vs " << b.size();
  EXPECT_NEAR(area_a / area_b, 1.0, 1e-4);
  // Only the instances' surfels, away from the ground: per unit area too.
  auto above = [](const std::vector<Surfel>& v) {
    size_t n = 0;
    for (const Surfel& s : v) n += s.position.y > -9.f;
    return n;
  };
  EXPECT_NEAR(double(above(a)) / double(above(b)), 1.0, 2e-3);
}

// Enough surfels for the Poisson sampler's octree to split (more than one
// tile's worth): instances go down it whole and are expanded where they
// straddle a split or end in a tile, with the flattened scene's surfels.
TEST(InstancedSurfels, PoissonOctreeSplitsInstancesLikeTheFlattenedTriangles) {
  const auto [inst, flat] = forty_instances();
  SurfelOptions o;
  o.sampler = SurfelSampler::kPoisson;
  o.target_surfels = 120000;
  const std::vector<Surfel> a = sample_surfels(inst, o), b = sample_surfels(flat, o);
  ASSERT_GT(b.size(), 100000u);  // several tiles of at most 32768 expected surfels
  expect_same_surfels(a, b);
}

// A prototype holding a quad twice (a duplicated wall) placed with a
// non-uniform scale: the copies are found in the prototype's space and
// counted once, as in the flattened scene.
TEST(InstancedSurfels, CoincidentCopiesInsideAPrototypeCountOnce) {
  TriangleSoup quad;
  quad.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  quad.indices = {0, 1, 2, 0, 2, 3, 1, 2, 3, 1, 3, 0};  // the same square, both diagonals
  quad.material = {0, 0, 0, 0};
  quad.mesh = {0, 0, 1, 1};
  quad.mesh_paths = {"/Proto/A", "/Proto/B"};
  Scene s;
  s.source_path = "coincident_instances";
  s.materials.resize(1);
  s.prototypes.push_back({"/Proto", quad});
  s.add_instance(0, test::placement(0.3f, V3f(3.f, 2.f, 1.f), V3f(0, 0, 0)));
  s.add_instance(0, test::placement(1.1f, V3f(-2.f, 4.f, 1.f), V3f(10, 0, 0)));  // mirrored
  SurfelOptions o;
  o.spacing = 0.05f;
  const std::vector<Surfel> surfels = sample_surfels(s, o);
  double first = 0, second = 0;
  for (const Surfel& x : surfels) (x.position.x < 5.f ? first : second) += x.area();
  EXPECT_NEAR(first, 6.0, 0.01 * 6.0);    // 3 x 2, once
  EXPECT_NEAR(second, 8.0, 0.01 * 8.0);   // 2 x 4, once
}

// Copies split across ranges (issue 20): two instances of a floor tile laid
// on top of each other and on a world floor, an instance elsewhere, and one
// 20 cm above (a surface of its own). Before the cross-range cover the
// world floor's area under the tiles counted three times (6.0 instead of
// 4.0).
TEST(InstancedSurfels, CoincidentCopiesAcrossInstancesAndTheWorldCountOnce) {
  TriangleSoup tile;
  tile.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  tile.indices = {0, 1, 2, 0, 2, 3};
  tile.material = {0, 0};
  tile.mesh = {0, 0};
  tile.mesh_paths = {"/Proto/tile"};
  Scene s;
  s.source_path = "coincident_across_instances";
  s.materials.resize(1);
  s.triangles.positions = {{0, 0, 0}, {2, 0, 0}, {2, 2, 0}, {0, 2, 0}};
  s.triangles.indices = {0, 1, 2, 0, 2, 3};
  s.triangles.material = {0, 0};
  s.triangles.mesh = {0, 0};
  s.triangles.mesh_paths = {"/floor"};
  s.prototypes.push_back({"/Proto", tile});
  s.add_instance(0, test::placement(0.f, V3f(1.f), V3f(0.5f, 0.5f, 0)));
  s.add_instance(0, test::placement(0.f, V3f(1.f), V3f(0.5f, 0.5f, 0)));
  s.add_instance(0, test::placement(0.f, V3f(1.f), V3f(5, 0, 0)));
  s.add_instance(0, test::placement(0.f, V3f(1.f), V3f(0.5f, 0.5f, 0.2f)));
  SurfelOptions o;
  o.spacing = 0.05f;
  const std::vector<Surfel> surfels = sample_surfels(s, o);
  double floor = 0, apart = 0, above = 0;
  for (const Surfel& x : surfels) {
    (x.position.x > 4.f ? apart : x.position.z > 0.1f ? above : floor) += x.area();
  }
  EXPECT_NEAR(floor, 4.0, 0.01 * 4.0);  // the world floor, the two tiles on it once
  EXPECT_NEAR(apart, 1.0, 0.01);
  EXPECT_NEAR(above, 1.0, 0.01);
}

INSTANTIATE_TEST_SUITE_P(Samplers, InstancedSurfels,
                         ::testing::Values(SurfelSampler::kUniform, SurfelSampler::kPoisson));

}  // namespace
}  // namespace pbgi
