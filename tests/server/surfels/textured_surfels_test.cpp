// Surfels of textured and vertex-coloured surfaces take their albedo and
// emission from the point they stand for; their shading under a dome.
#include "server/scene/ray_scene.h"
#include "server/scene/texture.h"
#include "server/surfels/surfels.h"
#include "tests/server/scene/test_scenes.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>

namespace pbgi {
namespace {

constexpr float kDark = 0.1f, kLight = 0.8f;

// The unit quad [0,1]^2 in z = 0 with st = (x, y) and a 16x16 texture of
// a 4x4 checkerboard: square (i, j) (j counted from the bottom, as t is)
// is light when i + j is odd.
Scene checker_scene() {
  Scene scene;
  scene.source_path = "checker";
  const uint32_t m = test::add_material(scene, C3f(0.5f, 0.5f, 0.5f));
  test::add_square_z(scene, 0.5f, 0.5f, 0.f, 0.5f, m, false, "/quad");
  for (const V3f& p : scene.triangles.positions) scene.triangles.uvs.push_back(V2f(p.x, p.y));
  std::vector<float> texels(16 * 16 * 3);
  for (uint32_t y = 0; y < 16; ++y)
    for (uint32_t x = 0; x < 16; ++x) {
      const uint32_t i = x / 4, j = (15 - y) / 4;  // image rows run down, t up
      const float v = (i + j) % 2 ? kLight : kDark;
      for (int c = 0; c < 3; ++c) texels[(y * 16 + x) * 3 + c] = c == 1 ? 0.5f * v : v;
    }
  TextureBinding& b = scene.materials[m].albedo_texture;
  b.texture = std::make_shared<const Texture>("checker", 16, 16, 3, texels);
  b.wrap_s = b.wrap_t = TextureWrap::Clamp;
  return scene;
}

float expected_checker(float x, float y) {
  const int i = std::min(3, int(x * 4.f)), j = std::min(3, int(y * 4.f));
  return (i + j) % 2 ? kLight : kDark;
}

// Distance from (x, y) to the nearest boundary between squares.
float edge_distance(float x, float y) {
  const float dx = std::fabs(x * 4.f - std::round(x * 4.f)) / 4.f;
  const float dy = std::fabs(y * 4.f - std::round(y * 4.f)) / 4.f;
  return std::min(dx, dy);
}

TEST(TexturedSurfels, AlbedoFollowsTheCheckerboard) {
  const Scene scene = checker_scene();
  SurfelOptions options;
  options.target_surfels = 4000;
  const std::vector<Surfel> surfels = sample_surfels(scene, options);
  ASSERT_GT(surfels.size(), 3000u);
  size_t checked = 0;
  double sum = 0.0, area = 0.0;
  for (const Surfel& s : surfels) {
    sum += s.albedo.x * s.area();
    area += s.area();
    // Away from the squares' edges (bilinear blur reaches half a texel,
    // 1/32) the albedo is the square's.
    if (edge_distance(s.position.x, s.position.y) < 0.04f) continue;
    const float want = expected_checker(s.position.x, s.position.y);
    ASSERT_NEAR(s.albedo.x, want, 2e-3f) << s.position;
    ASSERT_NEAR(s.albedo.y, 0.5f * want, 2e-3f) << s.position;
    ++checked;
  }
  EXPECT_GT(checked, 1500u);
  // Area-weighted, the surfels keep the texture's mean.
  EXPECT_NEAR(sum / area, 0.5 * (kDark + kLight), 0.01);
}

TEST(TexturedSurfels, CoarseSurfelsAverageTheTexture) {
  // Surfels much larger than a square see its mip-mapped mean, not a
  // point sample: every albedo lies near the mean, none at the extremes.
  const Scene scene = checker_scene();
  SurfelOptions options;
  options.target_surfels = 4;
  for (const Surfel& s : sample_surfels(scene, options)) {
    EXPECT_GT(s.albedo.x, kDark + 0.15f) << s.position;
    EXPECT_LT(s.albedo.x, kLight - 0.15f) << s.position;
  }
}

TEST(TexturedSurfels, EmissionTextureGivesSurfelEmissionAndRadiance) {
  Scene scene = checker_scene();
  Material& m = scene.materials[0];
  m.emission_texture = m.albedo_texture;
  m.emission_texture.scale = C3f(10.f, 10.f, 10.f);
  SurfelOptions options;
  options.target_surfels = 1000;
  for (const Surfel& s : sample_surfels(scene, options)) {
    if (edge_distance(s.position.x, s.position.y) < 0.04f) continue;
    const float want = 10.f * expected_checker(s.position.x, s.position.y);
    ASSERT_NEAR(s.emission.x, want, 2e-2f);
    ASSERT_EQ(s.radiance, s.emission);
  }
}

TEST(TexturedSurfels, DisplayColorPerFaceIsTheFallback) {
  // Two triangles, red and blue, from a uniform displayColor (the decoder
  // unwelds it per corner).
  Scene scene;
  const uint32_t m = test::add_material(scene, C3f(0.5f, 0.f, 0.5f));
  test::add_square_z(scene, 0.5f, 0.5f, 0.f, 0.5f, m);
  scene.materials[m].albedo_from_vertex_colors = true;
  TriangleSoup& t = scene.triangles;
  std::vector<V3f> positions;
  std::vector<uint32_t> indices;
  for (size_t i = 0; i < t.indices.size(); ++i) {
    positions.push_back(t.positions[t.indices[i]]);
    indices.push_back(uint32_t(i));
    t.colors.push_back(i < 3 ? C3f(1, 0, 0) : C3f(0, 0, 1));
  }
  t.positions = positions;
  t.indices = indices;
  SurfelOptions options;
  options.target_surfels = 500;
  size_t red = 0, blue = 0;
  for (const Surfel& s : sample_surfels(scene, options)) {
    // Triangle 0 is below the diagonal x = y.
    const bool first = s.position.x > s.position.y;
    EXPECT_EQ(s.albedo, first ? C3f(1, 0, 0) : C3f(0, 0, 1)) << s.position;
    (first ? red : blue)++;
  }
  EXPECT_GT(red, 100u);
  EXPECT_GT(blue, 100u);
}

TEST(TexturedSurfels, ShadedUnderAConstantDome) {
  // An open textured plane under a white dome of radiance 1: E = pi, so
  // radiance = albedo / pi * pi = albedo.
  Scene scene = checker_scene();
  Light dome;
  dome.kind = LightKind::Dome;
  dome.radiance = C3f(1, 1, 1);
  scene.lights.push_back(dome);
  const RayScene rays(scene);
  SurfelOptions options;
  options.target_surfels = 300;
  options.light_samples = 256;
  std::vector<Surfel> surfels = sample_surfels(scene, options);
  shade_direct(rays, options, surfels);
  for (const Surfel& s : surfels) EXPECT_NEAR(s.radiance.x / s.albedo.x, 1.f, 0.08f) << s.position;
}

}  // namespace
}  // namespace pbgi
