// Coincident coplanar surfaces through sampling and the gather: two copies
// of an emitting square (a duplicated mesh) must light receivers as one
// square does, and as the closed form says, with either sampler. The
// contract is the samplers' (coincident_surfaces.h): they never let
// coincident coplanar copies add up, so the gather, which cannot tell a
// duplicate from a second layer of real geometry, never sees doubled area. This replaces the gather-level
// HardCases.DISABLED_CoincidentCoplanarSurfacesDoNotAddUp, which fed
// duplicated surfels straight into the gather.
#include "server/gather/gather.h"
#include "server/surfels/surfels.h"
#include "tests/server/gather/surfel_tree.h"
#include "tests/server/scene/test_scenes.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

namespace pbgi {
namespace {

// The square [-1, 1]^2 at z = 1 facing down as a grid of n x n quads.
void add_emitter(Scene& s, int n, uint32_t material) {
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const float x0 = -1.f + 2.f * i / n, x1 = -1.f + 2.f * (i + 1) / n;
      const float y0 = -1.f + 2.f * j / n, y1 = -1.f + 2.f * (j + 1) / n;
      test::add_quad(s, V3f(x0, y0, 1), V3f(x0, y1, 1), V3f(x1, y1, 1), V3f(x1, y0, 1), material,
                     "/emitter" + std::to_string(n));
    }
}

std::vector<GatherResult> gather_all(const std::vector<Surfel>& surfels, const GatherOptions& o,
                                     const std::vector<Receiver>& rs) {
  const test::SurfelTree tree(surfels);
  Gatherer g(tree, o);
  std::vector<GatherResult> out(rs.size());
  g.gather_tile(rs, out);
  return out;
}

class CoincidentSurfaces : public ::testing::TestWithParam<SurfelSampler> {};

TEST_P(CoincidentSurfaces, DuplicatedEmitterLightsAsOneThroughSamplerAndGather) {
  const float L = 1.f;
  Scene one, two;
  const uint32_t m1 = test::add_material(one, {0, 0, 0}, {L, L, L});
  const uint32_t m2 = test::add_material(two, {0, 0, 0}, {L, L, L});
  add_emitter(one, 1, m1);
  add_emitter(two, 1, m2);
  add_emitter(two, 3, m2);  // the copy, tessellated differently
  SurfelOptions o;
  o.sampler = GetParam();
  o.spacing = 0.04f;
  const std::vector<Surfel> s1 = sample_surfels(one, o), s2 = sample_surfels(two, o);
  double a1 = 0, a2 = 0;
  for (const Surfel& s : s1) a1 += s.area();
  for (const Surfel& s : s2) a2 += s.area();
  EXPECT_NEAR(a2, a1, 0.01 * a1);

  std::vector<Receiver> rs;
  for (int i = 0; i < 8; ++i) rs.push_back({{-0.7f + 0.2f * float(i), 0.1f, 0.f}, {0, 0, 1}});
  for (const GatherMethod method : {GatherMethod::kPbgi, GatherMethod::kFpbgi}) {
    GatherOptions go;
    go.method = method;
    const std::vector<GatherResult> a = gather_all(s1, go, rs), b = gather_all(s2, go, rs);
    double worst = 0;
    for (size_t i = 0; i < rs.size(); ++i) {
      const double exact = test::rect_irradiance(L, -1, 1, -1, 1, rs[i].position.x, rs[i].position.y, 1);
      worst = std::max(worst, std::abs(b[i].irradiance.x / a[i].irradiance.x - 1.0));
      EXPECT_NEAR(b[i].irradiance.x, a[i].irradiance.x, 0.03 * a[i].irradiance.x) << i;
      EXPECT_NEAR(b[i].irradiance.x, exact, 0.05 * exact) << i;
    }
    std::printf("duplicated emitter (%s, %s sampler): worst |doubled / single - 1| = %.4f\n",
                method == GatherMethod::kPbgi ? "pbgi" : "fpbgi",
                GetParam() == SurfelSampler::kPoisson ? "Poisson" : "uniform", worst);
  }
}

INSTANTIATE_TEST_SUITE_P(Samplers, CoincidentSurfaces,
                         ::testing::Values(SurfelSampler::kUniform, SurfelSampler::kPoisson));

}  // namespace
}  // namespace pbgi
