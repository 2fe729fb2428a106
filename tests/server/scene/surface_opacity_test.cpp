// Opacity (server/scene/surface_opacity.h) through RayScene: a cutout card
// lets every kind of ray through its holes and stops them on the rest,
// also when the card is an instanced prototype; a fractional card stops
// a fraction of the rays equal to its opacity.
#include "server/scene/surface_opacity.h"
#include "server/scene/ray_scene.h"
#include "server/scene/texture.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <vector>

namespace pbgi {
namespace {

// A 1 x 1 card in z = 0, x, y in [0, 1], st = (x, y); behind it (z = -1) a
// wall that catches what passes.
Scene card_scene() {
  Scene s;
  s.source_path = "surface_opacity_test";
  s.materials.resize(2);  // 0: the card, 1: the wall
  s.triangles.positions = {{0, 0, 0},    {1, 0, 0},   {1, 1, 0},  {0, 1, 0},
                           {-5, -5, -1}, {5, -5, -1}, {5, 5, -1}, {-5, 5, -1}};
  s.triangles.uvs = {{0, 0}, {1, 0}, {1, 1}, {0, 1}, {0, 0}, {0, 0}, {0, 0}, {0, 0}};
  s.triangles.indices = {0, 1, 2, 0, 2, 3, 4, 5, 6, 4, 6, 7};
  s.triangles.material = {0, 0, 1, 1};
  s.triangles.mesh = {0, 0, 1, 1};
  s.triangles.mesh_paths = {"/Card", "/Wall"};
  s.triangles.double_sided = {1, 0};
  return s;
}

// Alpha 1 on the left half of the card (s < 0.5), 0 on the right.
void cut_right_half(Material& m) {
  std::vector<float> texels(8 * 8 * 4, 1.f);
  for (int y = 0; y < 8; ++y)
    for (int x = 4; x < 8; ++x) texels[(y * 8 + x) * 4 + 3] = 0.f;
  m.opacity_texture.texture = std::make_shared<const Texture>("half", 8, 8, 4, texels);
  m.opacity_texture.channel = TextureChannel::A;
  m.opacity_texture.wrap_s = m.opacity_texture.wrap_t = TextureWrap::Clamp;
  m.opacity_threshold = 0.5f;
}

// Which triangle a ray straight down -z at (x, y) hits first: 0/1 the card,
// 2/3 the wall.
uint32_t hit_at(const RayScene& rays, float x, float y) {
  return rays.intersect(V3f(x, y, 1.f), V3f(0, 0, -1)).triangle;
}

TEST(SurfaceOpacity, CutoutLetsCameraAndShadowRaysThroughItsHolesOnly) {
  Scene s = card_scene();
  cut_right_half(s.materials[0]);
  const RayScene rays(s);
  for (const float y : {0.1f, 0.5f, 0.9f}) {
    EXPECT_LT(hit_at(rays, 0.2f, y), 2u) << "opaque half";
    EXPECT_GE(hit_at(rays, 0.8f, y), 2u) << "cut-out half";
    EXPECT_TRUE(rays.occluded(V3f(0.2f, y, 1.f), V3f(0, 0, -1), 0.f, 1.5f));
    EXPECT_FALSE(rays.occluded(V3f(0.8f, y, 1.f), V3f(0, 0, -1), 0.f, 1.5f));
  }
  // From behind (double-sided card) the same holes.
  EXPECT_FALSE(rays.occluded(V3f(0.8f, 0.5f, -0.5f), V3f(0, 0, 1), 0.f, 1.f));
  EXPECT_TRUE(rays.occluded(V3f(0.2f, 0.5f, -0.5f), V3f(0, 0, 1), 0.f, 1.f));
  // Coverage, as surfels see it.
  EXPECT_EQ(surface_coverage(s, 0, 0.1f, 0.1f), 1.f);  // (0.2, 0.1)
  EXPECT_EQ(surface_coverage(s, 0, 0.7f, 0.1f), 0.f);  // (0.8, 0.7)
  EXPECT_EQ(surface_coverage(s, 2, 0.3f, 0.3f), 1.f);  // the opaque wall
}

TEST(SurfaceOpacity, ConstantCutoutBelowTheThresholdRemovesTheSurface) {
  Scene s = card_scene();
  s.materials[0].opacity = 0.3f;
  s.materials[0].opacity_threshold = 0.5f;
  const RayScene rays(s);
  EXPECT_GE(hit_at(rays, 0.5f, 0.5f), 2u);
  s.materials[0].opacity = 0.6f;
  const RayScene present(s);
  EXPECT_LT(hit_at(present, 0.5f, 0.5f), 2u);
}

TEST(SurfaceOpacity, FractionalOpacityStopsThatFractionOfTheRays) {
  Scene s = card_scene();
  s.materials[0].opacity = 0.25f;
  const RayScene rays(s);
  int stopped = 0, card_hits = 0;
  constexpr int kRays = 4000;
  for (int i = 0; i < kRays; ++i) {
    const float x = 0.05f + 0.9f * float(i % 63) / 63.f, y = 0.05f + 0.9f * float(i / 63) / 64.f;
    stopped += rays.occluded(V3f(x, y, 1.f), V3f(0, 0, -1), 0.f, 1.5f);
    card_hits += hit_at(rays, x, y) < 2u;
  }
  // Binomial: sigma = sqrt(0.25 * 0.75 / 4000) = 0.0068; 5 sigma.
  EXPECT_NEAR(stopped / double(kRays), 0.25, 0.035);
  EXPECT_NEAR(card_hits / double(kRays), 0.25, 0.035);
  // The same ray is always answered the same.
  EXPECT_EQ(rays.occluded(V3f(0.3f, 0.3f, 1.f), V3f(0, 0, -1), 0.f, 1.5f),
            rays.occluded(V3f(0.3f, 0.3f, 1.f), V3f(0, 0, -1), 0.f, 1.5f));
  EXPECT_FLOAT_EQ(surface_coverage(s, 0, 0.3f, 0.3f), 0.25f);
}

TEST(SurfaceOpacity, InstancedCutoutCardsHaveTheirHoles) {
  // The card as a prototype placed twice (once mirrored in x), the wall in
  // the world soup.
  const Scene flat = card_scene();
  Scene s;
  s.source_path = "surface_opacity_test-instanced";
  s.materials = flat.materials;
  cut_right_half(s.materials[0]);
  Prototype p;
  p.prim_path = "/Proto";
  p.triangles.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  p.triangles.uvs = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  p.triangles.indices = {0, 1, 2, 0, 2, 3};
  p.triangles.material = {0, 0};
  p.triangles.mesh = {0, 0};
  p.triangles.mesh_paths = {"/Proto/Card"};
  p.triangles.double_sided = {1};
  s.prototypes.push_back(p);
  s.triangles.positions = {{-5, -5, -1}, {5, -5, -1}, {5, 5, -1}, {-5, 5, -1}};
  s.triangles.indices = {0, 1, 2, 0, 2, 3};
  s.triangles.material = {1, 1};
  s.triangles.mesh = {0, 0};
  s.triangles.mesh_paths = {"/Wall"};
  s.triangles.double_sided = {0};
  s.add_instance(0, M44f());
  // Mirrored in x and moved: x -> 3 - x (its solid half at world x in
  // [2.5, 3], its holes at [2, 2.5]).
  M44f mirror = M44f().setScale(V3f(-1.f, 1.f, 1.f));
  mirror.translate(V3f(-3.f, 0.f, 0.f));
  s.add_instance(0, mirror);
  ASSERT_TRUE(s.instances[1].mirrored);
  const RayScene rays(s);
  // Instance 0: as the flat card.
  EXPECT_TRUE(rays.occluded(V3f(0.2f, 0.5f, 1.f), V3f(0, 0, -1), 0.f, 1.5f));
  EXPECT_FALSE(rays.occluded(V3f(0.8f, 0.5f, 1.f), V3f(0, 0, -1), 0.f, 1.5f));
  const V3f solid = V3f(0.2f, 0.5f, 0.f) * s.instances[1].local_to_world;
  const V3f hole = V3f(0.8f, 0.5f, 0.f) * s.instances[1].local_to_world;
  EXPECT_TRUE(rays.occluded(solid + V3f(0, 0, 1), V3f(0, 0, -1), 0.f, 1.5f));
  EXPECT_FALSE(rays.occluded(hole + V3f(0, 0, 1), V3f(0, 0, -1), 0.f, 1.5f));
  // Surfel coverage through the mirrored instance's swapped corners.
  const Hit h = rays.intersect(solid + V3f(0, 0, 1), V3f(0, 0, -1));
  ASSERT_TRUE(h.valid());
  EXPECT_EQ(surface_coverage(s, h.triangle, h.u, h.v), 1.f);
}

}  // namespace
}  // namespace pbgi
