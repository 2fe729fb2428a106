// Accuracy of the gather against closed-form irradiance: a uniformly
// emitting disk or sphere seen from a point subtends a cone of half angle
// alpha with uniform radiance L, which gives E = pi L sin^2(alpha) cos(tau)
// on a surface whose normal is at tau from the cone axis (tau + alpha <= 90
// degrees).
#include "server/gather/gather.h"
#include "surfel_shapes.h"
#include "surfel_tree.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <vector>

namespace pbgi {
namespace {

using Imath::C3f;
using Imath::V3f;
constexpr float kPi = 3.14159265358979f;

Receiver at_origin(const V3f& normal) { return {V3f(0), normal.normalized()}; }

// Normal at angle tau (radians) from +z, in the xz plane.
V3f tilted(float tau) { return {std::sin(tau), 0.f, std::cos(tau)}; }

// Disk of radius R at height H over the origin, facing down, radiance L.
std::unique_ptr<test::SurfelTree> disk_above(float R, float H, uint32_t count, float L) {
  std::vector<Surfel> s;
  test::add_disk(s, {0, 0, H}, {0, 0, -1}, R, count, C3f(L));
  return std::make_unique<test::SurfelTree>(std::move(s));
}

float disk_irradiance(float R, float H, float L, float tau) {
  const float sin2 = R * R / (R * R + H * H);
  return kPi * L * sin2 * std::cos(tau);
}

GatherOptions options(uint32_t res = 8, float omega = 0.03f) {
  GatherOptions o;
  o.microbuffer_resolution = res;
  o.max_solid_angle = omega;
  return o;
}

TEST(GatherAccuracy, LargeEmittingPlaneGivesPiL) {
  // Disk of radius 20 at height 1: covers all but the lowest 2.9 degrees of
  // the hemisphere, E = pi L * 400/401.
  const float L = 2.f;
  auto tree = disk_above(20.f, 1.f, 60000, L);
  Gatherer g(*tree, options());
  const GatherResult r = g.gather(at_origin({0, 0, 1}));
  const float expect = disk_irradiance(20.f, 1.f, L, 0.f);
  std::printf("large plane: E = %.4f expect %.4f (pi L = %.4f), AO = %.4f\n", r.irradiance.x,
              expect, kPi * L, r.ao);
  EXPECT_NEAR(r.irradiance.x, kPi * L, 0.05f * kPi * L);
  EXPECT_NEAR(r.irradiance.x, expect, 0.02f * expect);
  EXPECT_FLOAT_EQ(r.irradiance.x, r.irradiance.y);
  EXPECT_LT(r.ao, 0.02f);
}

TEST(GatherAccuracy, DiskEmitterMatchesClosedForm) {
  const float R = 1.f, H = 2.f, L = 1.f;
  auto tree = disk_above(R, H, 20000, L);
  Gatherer g(*tree, options());
  for (const float deg : {0.f, 30.f, 60.f}) {
    const float tau = deg * kPi / 180.f;
    const GatherResult r = g.gather(at_origin(tilted(tau)));
    const float expect = disk_irradiance(R, H, L, tau);
    std::printf("disk tau=%2.0f: E = %.5f expect %.5f (%+.2f%%) AO %.4f\n", deg, r.irradiance.x,
                expect, 100.f * (r.irradiance.x / expect - 1.f), r.ao);
    EXPECT_NEAR(r.irradiance.x, expect, 0.03f * expect) << "tau = " << deg;
    // AO of an unshadowed cap: 1 - sin^2(alpha) cos(tau).
    EXPECT_NEAR(r.ao, 1.f - expect / (kPi * L), 0.01f) << "tau = " << deg;
  }
}

TEST(GatherAccuracy, SphereEmitterMatchesClosedForm) {
  // Curved: nodes have wide normal cones, so this exercises the SH path.
  const float R = 0.5f, D = 2.f, L = 1.f;
  std::vector<Surfel> s;
  test::add_sphere(s, {0, 0, D}, R, 20000, C3f(L));
  test::SurfelTree tree(std::move(s));
  Gatherer g(tree, options());
  for (const float deg : {0.f, 45.f}) {
    const float tau = deg * kPi / 180.f;
    const GatherResult r = g.gather(at_origin(tilted(tau)));
    const float expect = kPi * L * (R * R) / (D * D) * std::cos(tau);
    std::printf("sphere tau=%2.0f: E = %.5f expect %.5f (%+.2f%%)\n", deg, r.irradiance.x, expect,
                100.f * (r.irradiance.x / expect - 1.f));
    EXPECT_NEAR(r.irradiance.x, expect, 0.05f * expect) << "tau = " << deg;
  }
}

// Mean relative error over receivers with tilted normals looking at a disk
// emitter, for one setting.
float mean_disk_error(const tree::TreeSource& tree, float R, float H, const GatherOptions& o) {
  Gatherer g(tree, o);
  float sum = 0.f;
  int n = 0;
  for (float deg = 0.f; deg <= 55.f; deg += 5.f) {
    for (float phi = 0.f; phi < 2.f * kPi; phi += kPi / 3.f) {
      const float tau = deg * kPi / 180.f;
      const V3f normal(std::sin(tau) * std::cos(phi), std::sin(tau) * std::sin(phi), std::cos(tau));
      const float expect = disk_irradiance(R, H, 1.f, tau);
      sum += std::abs(g.gather(at_origin(normal)).irradiance.x / expect - 1.f);
      ++n;
    }
  }
  return sum / float(n);
}

TEST(GatherAccuracy, ConvergesWithFinerCut) {
  // At N = 4 the pixel bound on the cut (0.13 sr) lets every setting apply.
  const float R = 1.f, H = 1.5f;
  auto tree = disk_above(R, H, 20000, 1.f);
  std::vector<float> err;
  for (const float omega : {0.1f, 0.03f, 0.01f, 0.003f}) {
    err.push_back(mean_disk_error(*tree, R, H, options(4, omega)));
    std::printf("max_solid_angle %.3f: mean |error| %.4f\n", omega, err.back());
  }
  EXPECT_LT(err[2], err[0]);
  EXPECT_LT(err[3], err[1]);
  EXPECT_LT(err[3], 0.005f);
}

// Irradiance at the origin (normal +z) from the disk of radius R at height
// H facing down, radiance 1, seen past a black half-plane at height h
// covering x < x0: a point p of the disk is visible when the segment to it
// crosses z = h at x = p.x h / H >= x0. Integrates cos cos / r^2 = H^2/r^4
// over the visible part on a fine polar grid.
double half_plane_reference(double R, double H, double h, double x0) {
  constexpr int kRings = 2000, kSectors = 2000;
  double sum = 0;
  for (int i = 0; i < kRings; ++i) {
    const double r0 = R * i / kRings, r1 = R * (i + 1) / kRings, rm = 0.5 * (r0 + r1);
    const double ring = 0.5 * (r1 * r1 - r0 * r0) * (2 * M_PI / kSectors);
    for (int j = 0; j < kSectors; ++j) {
      const double a = 2 * M_PI * (j + 0.5) / kSectors;
      if (rm * std::cos(a) * h / H < x0) continue;
      const double d2 = rm * rm + H * H;
      sum += H * H / (d2 * d2) * ring;
    }
  }
  return sum;
}

TEST(GatherAccuracy, OcclusionConvergesWithResolution) {
  // The default cut, finer microbuffers: the edge of an occluder across an
  // emitter is resolved better.
  const float R = 1.f, H = 2.f, h = 1.f;
  const std::vector<float> edges = {-0.35f, -0.15f, 0.1f, 0.3f};
  std::vector<double> reference;
  for (const float x0 : edges) reference.push_back(half_plane_reference(R, H, h, x0));
  std::vector<std::unique_ptr<test::SurfelTree>> trees;
  for (const float x0 : edges) {
    std::vector<Surfel> s;
    test::add_disk(s, {0, 0, H}, {0, 0, -1}, R, 8000, C3f(1));
    test::add_quad(s, {x0 - 4.f, -4.f, h}, {0, 8, 0}, {4, 0, 0}, 160, 80, C3f(0));  // faces -z
    trees.push_back(std::make_unique<test::SurfelTree>(std::move(s)));
  }
  std::vector<float> err;
  for (const uint32_t res : {4u, 8u, 16u, 32u}) {
    float sum = 0.f;
    for (size_t e = 0; e < edges.size(); ++e) {
      Gatherer g(*trees[e], options(res, 0.03f));
      const float E = g.gather(at_origin({0, 0, 1})).irradiance.x;
      sum += std::abs(float(E / reference[e]) - 1.f);
    }
    err.push_back(sum / float(edges.size()));
    std::printf("resolution %2u: mean |error| behind an occluder edge %.4f\n", res, err.back());
  }
  EXPECT_LT(err[2], err[0]);
  EXPECT_LT(err[3], err[1]);
  EXPECT_LT(err[3], 0.03f);
}

}  // namespace
}  // namespace pbgi
