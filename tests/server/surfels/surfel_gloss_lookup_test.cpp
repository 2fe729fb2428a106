// Glossy lobes found again from the scene (server/surfels/surfel_gloss_lookup.h):
// stored surfels lose their lobe; the lookup must give back exactly what
// sampling set, on both sides of a double-sided quad too, and clear it
// everywhere else.
#include "server/scene/ray_scene.h"
#include "server/surfels/surfel_gloss_lookup.h"
#include "server/surfels/surfels.h"
#include "tests/server/scene/test_scenes.h"

#include <gtest/gtest.h>

namespace pbgi {
namespace {

// A gold metal quad (roughness 0.15) facing +z, a white diffuse one beside
// it, a gold quad standing on the white one, and a gold quad lying on the
// white one facing down into it (a box's bottom face on a floor).
Scene gold_and_white() {
  Scene s;
  s.source_path = "gold-and-white";
  const uint32_t gold = test::add_material(s, {0.95f, 0.8f, 0.45f});
  s.materials[gold].roughness = 0.15f;
  s.materials[gold].metallic = 1.f;
  const uint32_t white = test::add_material(s, {0.8f, 0.8f, 0.8f});
  test::add_quad(s, V3f(0, 0, 0), V3f(1, 0, 0), V3f(1, 1, 0), V3f(0, 1, 0), gold, "/gold");
  test::add_quad(s, V3f(2, 0, 0), V3f(3, 0, 0), V3f(3, 1, 0), V3f(2, 1, 0), white, "/white");
  test::add_quad(s, V3f(2.5f, 0, 0), V3f(2.5f, 1, 0), V3f(2.5f, 1, 1), V3f(2.5f, 0, 1), gold, "/wall");
  test::add_quad(s, V3f(2.2f, 0.2f, 0), V3f(2.2f, 0.8f, 0), V3f(2.4f, 0.8f, 0), V3f(2.4f, 0.2f, 0), gold,
                 "/bottom");
  return s;
}

TEST(SurfelGlossLookup, GivesBackTheLobesSamplingSet) {
  const Scene scene = gold_and_white();
  const RayScene rays(scene);
  SurfelOptions o;
  o.target_surfels = 2000;
  const std::vector<Surfel> sampled = sample_surfels(scene, o);
  std::vector<Surfel> stored = sampled;
  size_t glossy = 0;
  for (Surfel& s : stored) {
    glossy += s.gloss.glossy() ? 1 : 0;
    s.gloss = {};  // what a page record keeps
  }
  ASSERT_GT(glossy, 500u);
  ASSERT_LT(glossy, sampled.size());
  size_t facing_down = 0;
  for (const Surfel& s : sampled) facing_down += s.gloss.glossy() && s.normal.z < -0.5f ? 1 : 0;
  ASSERT_GT(facing_down, 10u);  // the bottom face's surfels, on the floor
  const GlossLookupStats st = restore_surfel_gloss(rays, o.glossy_roughness, stored);
  EXPECT_EQ(st.glossy, glossy);
  EXPECT_EQ(st.missed, 0u);
  for (size_t i = 0; i < stored.size(); ++i) {
    EXPECT_EQ(stored[i].gloss.alpha, sampled[i].gloss.alpha) << i;
    EXPECT_EQ(stored[i].gloss.f0, sampled[i].gloss.f0) << i;
    EXPECT_EQ(stored[i].albedo, sampled[i].albedo) << i;  // left as stored
  }
  // glossy_roughness 0: no lobes at all.
  const GlossLookupStats none = restore_surfel_gloss(rays, 0.f, stored);
  EXPECT_EQ(none.glossy, 0u);
  for (const Surfel& s : stored) EXPECT_FALSE(s.gloss.glossy());
}

TEST(SurfelGlossLookup, ASurfelOffEverySurfaceIsCountedNotGuessed) {
  const Scene scene = gold_and_white();
  const RayScene rays(scene);
  Surfel s;
  s.position = V3f(0.5f, 0.5f, 0.3f);  // above the gold quad, on nothing
  s.normal = V3f(0, 0, 1);
  s.radius = 0.01f;
  s.gloss.alpha = 0.5f;
  s.gloss.f0 = C3f(1.f);
  std::vector<Surfel> one{s};
  const GlossLookupStats st = restore_surfel_gloss(rays, 0.3f, one);
  EXPECT_EQ(st.missed, 1u);
  EXPECT_EQ(st.glossy, 0u);
  EXPECT_FALSE(one[0].gloss.glossy());
}

}  // namespace
}  // namespace pbgi
