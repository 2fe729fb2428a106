// Multiple bounces at build time: a closed emitting box (a "furnace") has
// an exact answer after B bounces, L = Le (1 + rho + ... + rho^(B-1)).
#include "server/gather/surfel_bounce.h"
#include "storage/format/errors.h"
#include "surfel_shapes.h"
#include "surfel_tree.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

namespace pbgi {
namespace {

using Imath::C3f;
using Imath::V3f;

// The inside of a 2 m box, every surfel emitting Le with albedo rho.
std::vector<Surfel> furnace(float Le, float rho) {
  std::vector<Surfel> s;
  const float S = 2.f;
  const uint32_t n = 40;
  test::add_quad(s, {0, 0, 0}, {S, 0, 0}, {0, S, 0}, n, n, C3f(Le));
  test::add_quad(s, {0, 0, S}, {0, S, 0}, {S, 0, 0}, n, n, C3f(Le));
  test::add_quad(s, {0, 0, 0}, {0, S, 0}, {0, 0, S}, n, n, C3f(Le));
  test::add_quad(s, {S, 0, 0}, {0, 0, S}, {0, S, 0}, n, n, C3f(Le));
  test::add_quad(s, {0, 0, 0}, {0, 0, S}, {S, 0, 0}, n, n, C3f(Le));
  test::add_quad(s, {0, S, 0}, {S, 0, 0}, {0, 0, S}, n, n, C3f(Le));
  for (Surfel& x : s) x.albedo = C3f(rho, rho, 0.f);  // blue reflects nothing
  return s;
}

TEST(SurfelBounce, FurnaceConvergesToTheGeometricSeries) {
  const float Le = 1.f, rho = 0.5f;
  for (uint32_t bounces = 1; bounces <= 4; ++bounces) {
    const std::vector<Surfel> out =
        add_bounces(furnace(Le, rho), bounces, tree::BuildOptions{}, GatherOptions{});
    ASSERT_EQ(out.size(), 6u * 40u * 40u);
    double expect = 0, term = Le;
    for (uint32_t b = 0; b < bounces; ++b, term *= rho) expect += term;
    // Away from the box's edges every surfel sees the closed box.
    double sum = 0;
    size_t count = 0;
    for (const Surfel& s : out) {
      bool inner = true;
      for (int a = 0; a < 3; ++a) {
        if (std::abs(s.normal[a]) < 0.5f && (s.position[a] < 0.3f || s.position[a] > 1.7f))
          inner = false;
      }
      if (!inner) continue;
      sum += s.radiance.x;
      ++count;
      EXPECT_NEAR(s.radiance.x, expect, 0.02 * expect) << "bounces " << bounces;
      EXPECT_FLOAT_EQ(s.radiance.z, Le);  // no albedo: emission only
    }
    std::printf("furnace, %u bounce(s): mean radiance %.4f, exact %.4f\n", bounces,
                sum / double(count), expect);
    EXPECT_GT(count, 1000u);
  }
}

TEST(SurfelBounce, FactorizedBouncesAgree) {
  GatherOptions o;
  o.method = GatherMethod::kFpbgi;
  const std::vector<Surfel> f = add_bounces(furnace(1.f, 0.5f), 3, tree::BuildOptions{}, o);
  const std::vector<Surfel> p =
      add_bounces(furnace(1.f, 0.5f), 3, tree::BuildOptions{}, GatherOptions{});
  ASSERT_EQ(f.size(), p.size());
  double worst = 0;
  for (size_t i = 0; i < f.size(); ++i) {
    worst = std::max(worst, double(std::abs(f[i].radiance.x - p[i].radiance.x)));
  }
  std::printf("factorized vs plain bounces: worst radiance difference %.4f (of 1.75)\n", worst);
  EXPECT_LT(worst, 0.03);
}

TEST(SurfelBounce, GatherBounceAddsReflectedLightOnce) {
  // A white floor under an emitting disk: the floor's new radiance is its
  // direct term plus albedo/pi times the irradiance from the disk.
  std::vector<Surfel> s;
  test::add_disk(s, {0, 0, 2}, {0, 0, -1}, 1.f, 4000, C3f(1));  // E at origin: pi/5
  std::vector<Surfel> floor;
  test::add_quad(floor, {-0.1f, -0.1f, 0}, {0.2f, 0, 0}, {0, 0.2f, 0}, 4, 4, C3f(0.3f));
  for (Surfel& x : floor) {
    x.albedo = C3f(0.6f);
    x.emission = C3f(0);
  }
  s.insert(s.end(), floor.begin(), floor.end());
  test::SurfelTree tree(s);
  std::vector<C3f> direct(floor.size(), C3f(0.3f));
  gather_bounce(tree, floor, direct, GatherOptions{});
  for (const Surfel& x : floor) {
    const float expect = 0.3f + 0.6f / 3.14159265f * (3.14159265f / 5.f);
    EXPECT_NEAR(x.radiance.x, expect, 0.01f);
  }
  std::vector<C3f> wrong(floor.size() + 1);
  EXPECT_THROW(gather_bounce(tree, floor, wrong, GatherOptions{}), InvalidArgument);
  EXPECT_THROW(add_bounces(floor, 5, tree::BuildOptions{}, GatherOptions{}), InvalidArgument);
  EXPECT_THROW(add_bounces(floor, 0, tree::BuildOptions{}, GatherOptions{}), InvalidArgument);
}

}  // namespace
}  // namespace pbgi
