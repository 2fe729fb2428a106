// Glossy senders (server/surfels/surfel_material.h): a material whose GGX
// roughness is below glossy_roughness gives its surfels the lobe (a metal's
// diffuse part black), rougher ones stay Lambertian with the full albedo,
// and glossy_roughness 0 turns the lobes off.
#include "common/errors.h"
#include "server/scene/brdf.h"
#include "server/surfels/surfels.h"
#include "tests/server/scene/test_scenes.h"

#include <gtest/gtest.h>

namespace pbgi {
namespace {

// Three quads: a gold metal (roughness 0.15), a rough metal (0.6) and a
// diffuse white (roughness 1, metallic 0).
Scene three_materials() {
  Scene s;
  s.source_path = "three";
  const uint32_t gold = test::add_material(s, {0.95f, 0.8f, 0.45f});
  s.materials[gold].roughness = 0.15f;
  s.materials[gold].metallic = 1.f;
  const uint32_t rough = test::add_material(s, {0.6f, 0.6f, 0.6f});
  s.materials[rough].roughness = 0.6f;
  s.materials[rough].metallic = 1.f;
  const uint32_t white = test::add_material(s, {0.8f, 0.8f, 0.8f});
  test::add_quad(s, V3f(0, 0, 0), V3f(1, 0, 0), V3f(1, 1, 0), V3f(0, 1, 0), gold, "/gold");
  test::add_quad(s, V3f(2, 0, 0), V3f(3, 0, 0), V3f(3, 1, 0), V3f(2, 1, 0), rough, "/rough");
  test::add_quad(s, V3f(4, 0, 0), V3f(5, 0, 0), V3f(5, 1, 0), V3f(4, 1, 0), white, "/white");
  return s;
}

TEST(SurfelMaterial, GlossyMaterialsKeepTheirLobeAndRougherOnesStayLambertian) {
  const Scene s = three_materials();
  SurfelOptions o;
  o.target_surfels = 600;
  const BrdfLobes gold = brdf_lobes(s.materials[0], s.materials[0].albedo);
  size_t glossy = 0, rough = 0, white = 0;
  for (const Surfel& x : sample_surfels(s, o)) {
    if (x.position.x < 1.5f) {
      ++glossy;
      ASSERT_TRUE(x.gloss.glossy());
      EXPECT_FLOAT_EQ(x.gloss.alpha, gold.alpha);  // roughness^2
      EXPECT_EQ(x.gloss.f0, gold.f0);              // the metal's colour
      EXPECT_EQ(x.albedo, C3f(0, 0, 0));           // a metal has no diffuse part
    } else if (x.position.x < 3.5f) {
      ++rough;
      EXPECT_FALSE(x.gloss.glossy());
      EXPECT_EQ(x.albedo, C3f(0.6f, 0.6f, 0.6f));  // Lambertian, as before glossy senders
    } else {
      ++white;
      EXPECT_FALSE(x.gloss.glossy());
    }
  }
  EXPECT_GT(glossy, 50u);
  EXPECT_GT(rough, 50u);
  EXPECT_GT(white, 50u);
}

TEST(SurfelMaterial, GlossyRoughnessZeroTurnsLobesOff) {
  const Scene s = three_materials();
  SurfelOptions o;
  o.target_surfels = 600;
  o.glossy_roughness = 0.f;
  for (const Surfel& x : sample_surfels(s, o)) {
    EXPECT_FALSE(x.gloss.glossy());
    if (x.position.x < 1.5f) {
      EXPECT_EQ(x.albedo, C3f(0.95f, 0.8f, 0.45f));
    }
  }
  o.glossy_roughness = 1.5f;
  EXPECT_THROW(o.validate(), InvalidArgument);
}

}  // namespace
}  // namespace pbgi
