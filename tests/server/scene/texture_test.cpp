// Texture lookups (UsdUVTexture conventions) and material evaluation with
// textures and vertex colours.
#include "server/scene/texture.h"
#include "common/errors.h"
#include "server/scene/surface_colors.h"
#include "tests/server/scene/test_scenes.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>

namespace pbgi {
namespace {

using Imath::V4f;

// A w x h single-channel texture whose texel (x, y) (y down) holds f(x, y).
template <typename F>
std::shared_ptr<const Texture> grey_texture(uint32_t w, uint32_t h, F f) {
  std::vector<float> t(size_t(w) * h);
  for (uint32_t y = 0; y < h; ++y)
    for (uint32_t x = 0; x < w; ++x) t[size_t(y) * w + x] = f(x, y);
  return std::make_shared<const Texture>("test", w, h, 1, t);
}

TEST(Texture, TexelCentresAreExactAndTIsUp) {
  // 2x2: top row (y = 0) 0.1, 0.2; bottom row 0.3, 0.4.
  const auto tex = grey_texture(2, 2, [](uint32_t x, uint32_t y) { return 0.1f + 0.1f * float(x + 2 * y); });
  const auto at = [&](float s, float t) { return tex->lookup({s, t}, TextureWrap::Clamp, TextureWrap::Clamp).x; };
  EXPECT_NEAR(at(0.25f, 0.75f), 0.1f, 1e-3f);  // top-left texel: t near 1
  EXPECT_NEAR(at(0.75f, 0.75f), 0.2f, 1e-3f);
  EXPECT_NEAR(at(0.25f, 0.25f), 0.3f, 1e-3f);  // bottom-left: t near 0
  EXPECT_NEAR(at(0.75f, 0.25f), 0.4f, 1e-3f);
  // Bilinear halfway between the two top texels.
  EXPECT_NEAR(at(0.5f, 0.75f), 0.15f, 1e-3f);
  EXPECT_NEAR(at(0.5f, 0.5f), 0.25f, 1e-3f);
}

TEST(Texture, WrapModes) {
  // 4x1 ramp 0, 1, 2, 3.
  const auto tex = grey_texture(4, 1, [](uint32_t x, uint32_t) { return float(x); });
  const auto at = [&](float s, TextureWrap w) { return tex->lookup({s, 0.5f}, w, TextureWrap::Clamp).x; };
  // s = 1.125 is the centre of texel 4, i.e. texel 0 repeated, 3 clamped,
  // 3 mirrored (the mirror image of texel 3), black outside.
  EXPECT_NEAR(at(1.125f, TextureWrap::Repeat), 0.f, 1e-3f);
  EXPECT_NEAR(at(1.125f, TextureWrap::Clamp), 3.f, 1e-3f);
  EXPECT_NEAR(at(1.125f, TextureWrap::Mirror), 3.f, 1e-3f);
  EXPECT_NEAR(at(1.375f, TextureWrap::Mirror), 2.f, 1e-3f);
  EXPECT_NEAR(at(1.125f, TextureWrap::Black), 0.f, 1e-3f);
  EXPECT_NEAR(tex->lookup({1.125f, 0.5f}, TextureWrap::Black, TextureWrap::Clamp).w, 0.f, 1e-6f);
  EXPECT_NEAR(at(-0.125f, TextureWrap::Repeat), 3.f, 1e-3f);
  EXPECT_NEAR(at(-0.125f, TextureWrap::Clamp), 0.f, 1e-3f);
  // UseMetadata left unresolved behaves as repeat.
  EXPECT_NEAR(at(1.125f, TextureWrap::UseMetadata), 0.f, 1e-3f);
}

TEST(Texture, LargeFootprintAveragesToTheMean) {
  // 64x64 checker of 8x8 squares, 0 and 1: mean 0.5.
  const auto tex = grey_texture(64, 64, [](uint32_t x, uint32_t y) { return float(((x / 8) + (y / 8)) % 2); });
  EXPECT_NEAR(tex->mean().x, 0.5f, 1e-6f);
  EXPECT_EQ(tex->level_count(), 7u);
  // A footprint of the whole texture reads the 1x1 level.
  EXPECT_NEAR(tex->lookup({0.3f, 0.7f}, TextureWrap::Repeat, TextureWrap::Repeat, 1.f).x, 0.5f, 1e-3f);
  // A footprint of one 8x8 square centred on a square averages it only.
  const float s = (8.f + 4.f) / 64.f, t = 1.f - (0.f + 4.f) / 64.f;  // texel (12, 4): square (1, 0) = 1
  EXPECT_NEAR(tex->lookup({s, t}, TextureWrap::Repeat, TextureWrap::Repeat, 0.f).x, 1.f, 1e-3f);
  EXPECT_NEAR(tex->lookup({s, t}, TextureWrap::Repeat, TextureWrap::Repeat, 4.f / 64.f).x, 1.f, 1e-3f);
}

TEST(Texture, OddSizesKeepTheMeanThroughThePyramid) {
  const auto tex = grey_texture(5, 3, [](uint32_t x, uint32_t y) { return float(x * 3 + y); });
  const float mean = (0 + 14) / 2.f;
  EXPECT_NEAR(tex->mean().x, mean, 1e-5f);
  EXPECT_NEAR(tex->lookup({0.5f, 0.5f}, TextureWrap::Clamp, TextureWrap::Clamp, 100.f).x, mean, 0.02f);
}

TEST(Texture, RejectsInconsistentSizes) {
  EXPECT_THROW(Texture("bad", 2, 2, 3, std::vector<float>(11)), InvalidArgument);
  EXPECT_THROW(Texture("bad", 0, 2, 1, {}), InvalidArgument);
  EXPECT_THROW(Texture("bad", 1, 1, 5, std::vector<float>(5)), InvalidArgument);
}

TEST(TextureBinding, ChannelScaleBiasAndTransform) {
  // 2x1 RGBA: left (0.1, 0.2, 0.3, 0.4), right (0.5, 0.6, 0.7, 0.8).
  TextureBinding b;
  b.texture = std::make_shared<const Texture>(
      "rgba", 2, 1, 4, std::vector<float>{0.1f, 0.2f, 0.3f, 0.4f, 0.5f, 0.6f, 0.7f, 0.8f});
  b.wrap_s = b.wrap_t = TextureWrap::Clamp;
  const V2f left(0.25f, 0.5f), right(0.75f, 0.5f);
  EXPECT_NEAR(evaluate_texture(b, left).y, 0.2f, 1e-3f);
  b.channel = TextureChannel::A;
  EXPECT_NEAR(evaluate_texture(b, right).x, 0.8f, 1e-3f);
  EXPECT_NEAR(evaluate_texture(b, right).z, 0.8f, 1e-3f);
  b.scale = C3f(2.f, 2.f, 2.f);
  b.bias = C3f(0.1f, 0.1f, 0.1f);
  EXPECT_NEAR(evaluate_texture(b, right).y, 1.7f, 1e-3f);
  // st' = st * M: s' = 1 - s (a mirror) sends left to right.
  b.st_transform = Imath::M33f(-1, 0, 0, 0, 1, 0, 1, 0, 1);
  EXPECT_NEAR(evaluate_texture(b, left).x, 1.7f, 1e-3f);
  // A constant st ignores the point's st.
  b.uses_uvs = false;
  b.constant_st = V2f(0.75f, 0.5f);  // mirrored: left texel, alpha 0.4
  EXPECT_NEAR(evaluate_texture(b, right).x, 0.9f, 1e-3f);
  EXPECT_NEAR(evaluate_texture_mean(b).x, 0.9f, 1e-3f);
}

// A unit quad in z = 0 with st = (x, y), textured with a 2x2 checker.
Scene checker_quad(bool with_uvs) {
  Scene scene;
  const uint32_t m = test::add_material(scene, C3f(0.5f, 0.5f, 0.5f));
  test::add_square_z(scene, 0.5f, 0.5f, 0.f, 0.5f, m);
  if (with_uvs)
    for (const V3f& p : scene.triangles.positions) scene.triangles.uvs.push_back(V2f(p.x, p.y));
  Material& mat = scene.materials[m];
  mat.albedo_texture.texture = grey_texture(2, 2, [](uint32_t x, uint32_t y) { return (x + y) % 2 ? 0.8f : 0.1f; });
  mat.albedo_texture.wrap_s = mat.albedo_texture.wrap_t = TextureWrap::Repeat;
  return scene;
}

// Barycentrics (of vertices 1 and 2) of (x, y) in the quad's triangle 0
// (vertices (0,0), (1,0), (1,1)) or 1 ((0,0), (1,1), (0,1)).
SurfaceColors at(const Scene& scene, float x, float y) {
  if (x >= y) return surface_colors(scene, 0, x - y, y);
  return surface_colors(scene, 1, x, y - x);
}

TEST(SurfaceColors, TexturedAlbedoFollowsUvs) {
  const Scene scene = checker_quad(true);
  // Texel (0, 0) is the top-left: st (0.25, 0.75) -> 0.1; (0.75, 0.75) -> 0.8.
  EXPECT_NEAR(at(scene, 0.25f, 0.75f).albedo.x, 0.1f, 1e-3f);
  EXPECT_NEAR(at(scene, 0.75f, 0.75f).albedo.x, 0.8f, 1e-3f);
  EXPECT_NEAR(at(scene, 0.25f, 0.25f).albedo.x, 0.8f, 1e-3f);
  EXPECT_NEAR(at(scene, 0.75f, 0.25f).albedo.x, 0.1f, 1e-3f);
  // A footprint as large as the quad averages the checker.
  EXPECT_NEAR(surface_colors(scene, 0, 0.5f, 0.25f, 1.f).albedo.x, 0.45f, 1e-2f);
  EXPECT_EQ(at(scene, 0.25f, 0.75f).emission, C3f(0, 0, 0));
}

TEST(SurfaceColors, MeshWithoutUvsGetsTheTextureMean) {
  Scene scene = checker_quad(false);
  EXPECT_NEAR(at(scene, 0.25f, 0.75f).albedo.x, 0.45f, 1e-3f);
  // NaN uvs (a mesh without them in a scene with uvs) do the same.
  scene.triangles.uvs.assign(scene.triangles.positions.size(), V2f(NAN, NAN));
  EXPECT_NEAR(at(scene, 0.25f, 0.75f).albedo.x, 0.45f, 1e-3f);
}

TEST(SurfaceColors, VertexColorsInterpolateAndTexturesWin) {
  Scene scene;
  const uint32_t m = test::add_material(scene, C3f(0.5f, 0.5f, 0.5f));
  test::add_square_z(scene, 0.5f, 0.5f, 0.f, 0.5f, m);
  scene.materials[m].albedo_from_vertex_colors = true;
  scene.triangles.colors = {C3f(1, 0, 0), C3f(0, 1, 0), C3f(0, 0, 1), C3f(1, 1, 1)};
  const SurfaceColors c = surface_colors(scene, 0, 0.25f, 0.5f);  // 0.25 red, 0.25 green, 0.5 blue
  EXPECT_NEAR(c.albedo.x, 0.25f, 1e-6f);
  EXPECT_NEAR(c.albedo.y, 0.25f, 1e-6f);
  EXPECT_NEAR(c.albedo.z, 0.5f, 1e-6f);
  // Without the flag the constant stands.
  scene.materials[m].albedo_from_vertex_colors = false;
  EXPECT_EQ(surface_colors(scene, 0, 0.25f, 0.5f).albedo, C3f(0.5f, 0.5f, 0.5f));
}

TEST(SurfaceColors, EmissionTexture) {
  Scene scene = checker_quad(true);
  Material& mat = scene.materials[0];
  mat.emission_texture = mat.albedo_texture;
  mat.emission_texture.scale = C3f(10.f, 10.f, 10.f);
  EXPECT_NEAR(at(scene, 0.75f, 0.75f).emission.x, 8.f, 1e-2f);
}

}  // namespace
}  // namespace pbgi
