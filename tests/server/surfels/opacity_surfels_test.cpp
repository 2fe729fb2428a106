// Surfels of cut-out and partly transparent surfaces
// (server/scene/surface_opacity.h): no surfel where a cutout removes the
// surface, and surfels of a fractional surface cover its opacity times
// its area -- with both samplers.
#include "server/scene/surface_opacity.h"
#include "server/scene/texture.h"
#include "server/surfels/surfels.h"

#include <gtest/gtest.h>

#include <memory>
#include <vector>

namespace pbgi {
namespace {

// A double-sided 1 x 1 card in z = 0, x, y in [0, 1], st = (x, y).
Scene card() {
  Scene s;
  s.source_path = "opacity_surfels_test";
  s.materials.resize(1);
  s.triangles.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  s.triangles.uvs = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  s.triangles.indices = {0, 1, 2, 0, 2, 3};
  s.triangles.material = {0, 0};
  s.triangles.mesh = {0, 0};
  s.triangles.mesh_paths = {"/Card"};
  s.triangles.double_sided = {1};
  return s;
}

class OpacitySurfels : public ::testing::TestWithParam<SurfelSampler> {
 protected:
  std::vector<Surfel> sample(const Scene& s) const {
    SurfelOptions o;
    o.sampler = GetParam();
    o.target_surfels = 4000;
    return sample_surfels(s, o);
  }
  static double area(const std::vector<Surfel>& surfels) {
    double a = 0.0;
    for (const Surfel& x : surfels) a += x.area();
    return a;
  }
};

TEST_P(OpacitySurfels, NoSurfelWhereACutoutRemovesTheSurface) {
  Scene s = card();
  std::vector<float> texels(8 * 8 * 4, 1.f);  // alpha 0 on the right half
  for (int y = 0; y < 8; ++y)
    for (int x = 4; x < 8; ++x) texels[(y * 8 + x) * 4 + 3] = 0.f;
  Material& m = s.materials[0];
  m.opacity_texture.texture = std::make_shared<const Texture>("half", 8, 8, 4, texels);
  m.opacity_texture.channel = TextureChannel::A;
  m.opacity_texture.wrap_s = m.opacity_texture.wrap_t = TextureWrap::Clamp;
  m.opacity_threshold = 0.5f;
  const std::vector<Surfel> opaque = sample(card()), cut = sample(s);
  ASSERT_GT(cut.size(), 0u);
  size_t left = 0;
  for (const Surfel& x : cut) {
    EXPECT_LT(x.position.x, 0.5f + 1.f / 16.f) << "a surfel in the hole at x = " << x.position.x;
    left += x.position.x < 0.5f;
  }
  // The left half keeps its surfels, full-sized.
  EXPECT_NEAR(double(cut.size()), 0.5 * double(opaque.size()), 0.1 * double(opaque.size()));
  EXPECT_NEAR(area(cut), 0.5 * area(opaque), 0.08 * area(opaque));
  EXPECT_GT(left, cut.size() * 9 / 10);
}

TEST_P(OpacitySurfels, FractionalSurfelsCoverTheOpacityOfTheArea) {
  Scene s = card();
  s.materials[0].opacity = 0.3f;
  const std::vector<Surfel> opaque = sample(card()), veil = sample(s);
  EXPECT_EQ(veil.size(), opaque.size());  // everywhere, each smaller
  EXPECT_NEAR(area(veil), 0.3 * area(opaque), 1e-3 * area(opaque));
}

INSTANTIATE_TEST_SUITE_P(Samplers, OpacitySurfels, ::testing::Values(SurfelSampler::kUniform, SurfelSampler::kPoisson),
                         [](const auto& info) {
                           return info.param == SurfelSampler::kUniform ? "Uniform" : "Poisson";
                         });

}  // namespace
}  // namespace pbgi
