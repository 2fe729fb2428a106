// Microbuffer compositing and rasterization, checked through the resolved
// irradiance and AO.
#include "server/gather/cube_layout.h"
#include "server/gather/microbuffer.h"
#include "server/gather/rasterizer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace pbgi::gather {
namespace {

using Imath::C3f;
using Imath::V3f;
constexpr float kPi = 3.14159265358979f;

// Irradiance of a uniform cap of half angle alpha around the normal.
float cap_irradiance(float alpha, float L) { return kPi * L * std::sin(alpha) * std::sin(alpha); }
float cap_solid_angle(float alpha) { return 2.f * kPi * (1.f - std::cos(alpha)); }

Rasterizer::Shape round(float omega) {
  Rasterizer::Shape s;
  s.omega = omega;
  return s;
}

// Pixel of the +z face nearest the normal (0,0,1) and its weight.
uint32_t center_pixel(const CubeLayout& c) {
  return c.index(4, c.resolution() / 2, c.resolution() / 2);
}

TEST(Microbuffer, PiecesOfOneSurfaceAddUp) {
  const CubeLayout& c = CubeLayout::get(8);
  Microbuffer mb(c, 0.2f);
  mb.begin(V3f(0, 0, 1));
  const uint32_t k = center_pixel(c);
  mb.add_coverage(k, 1.0f, 0.3f, 0.3f * mb.weight(k), C3f(1));
  mb.add_coverage(k, 1.1f, 0.3f, 0.3f * mb.weight(k), C3f(1));  // within the band: same surface
  const Resolved r = mb.resolve(0.f);
  EXPECT_NEAR(r.irradiance.x, 0.6f * mb.weight(k), 1e-6f);
  EXPECT_NEAR(r.ao, 1.f - 0.6f * mb.weight(k) / kPi, 1e-6f);
}

TEST(Microbuffer, NearerSurfaceHidesItsShareOfFartherOne) {
  const CubeLayout& c = CubeLayout::get(8);
  Microbuffer mb(c, 0.2f);
  const uint32_t k = center_pixel(c);
  for (const bool near_first : {true, false}) {
    mb.begin(V3f(0, 0, 1));
    const auto near = [&] { mb.add_coverage(k, 0.5f, 0.4f, 0.4f * mb.weight(k), C3f(0)); };
    const auto far = [&] { mb.add_coverage(k, 2.0f, 1.0f, 1.0f * mb.weight(k), C3f(1)); };
    if (near_first) {
      near();
      far();
    } else {
      far();
      near();
    }
    const Resolved r = mb.resolve(0.f);
    EXPECT_NEAR(r.irradiance.x, 0.6f * mb.weight(k), 1e-6f) << near_first;
    EXPECT_NEAR(r.ao, 1.f - mb.weight(k) / kPi, 1e-6f);
    // AO limited to 1: only the near layer counts.
    mb.begin(V3f(0, 0, 1));
    near();
    far();
    EXPECT_NEAR(mb.resolve(1.f).ao, 1.f - 0.4f * mb.weight(k) / kPi, 1e-6f);
  }
}

TEST(Microbuffer, RayCastHitsDoNotAddUpButHideWhatIsBehind) {
  const CubeLayout& c = CubeLayout::get(8);
  Microbuffer mb(c, 0.2f);
  mb.begin(V3f(0, 0, 1));
  const uint32_t k = center_pixel(c);
  mb.add_hit(k, 0.5f, C3f(2));
  mb.add_hit(k, 0.52f, C3f(4));  // overlapping disk of the same surface
  mb.add_coverage(k, 3.f, 1.f, 1.f * mb.weight(k), C3f(100));
  const Resolved r = mb.resolve(0.f);
  EXPECT_NEAR(r.irradiance.x, 3.f * mb.weight(k), 1e-5f);
}

// Issue 20: a wall seen from inside a room, and the lit ground just behind
// its foot, within the depth band of the wall. Before surfaces were told
// apart the two joined one cluster and the ground's light added to the
// wall's (irradiance 1.0 x weight here instead of 0).
TEST(Microbuffer, SurfaceBehindAnotherWithinTheBandIsHidden) {
  const CubeLayout& c = CubeLayout::get(8);
  Microbuffer mb(c, 0.2f);
  const uint32_t k = center_pixel(c);
  const V3f d = c.direction(k);
  // The wall faces the receiver (normal -d) at depth 1; the ground, facing
  // up across the ray, meets it at depth 1.1 (behind the wall's plane).
  const FragmentSurface wall{-d, -1.f, 1e-3f};
  const V3f up = V3f(0, 1, 0) - d * d.y;  // across the ray, facing the receiver side
  const V3f n_ground = (up.normalized() - d * 0.5f).normalized();
  const FragmentSurface ground{n_ground, 1.1f * n_ground.dot(d), 1e-3f};
  for (const bool wall_first : {true, false}) {
    mb.begin(V3f(0, 0, 1));
    const auto add_wall = [&] { mb.add_coverage(k, 1.0f, 1.0f, 1.0f, mb.weight(k), C3f(0), wall); };
    // The ground's splat sits at its node's center, nearer than the wall's.
    const auto add_ground = [&] { mb.add_coverage(k, 0.95f, 0.95f, 0.8f, 0.8f * mb.weight(k), C3f(1), ground); };
    if (wall_first) {
      add_wall();
      add_ground();
    } else {
      add_ground();
      add_wall();
    }
    const Resolved r = mb.resolve(0.f);
    EXPECT_NEAR(r.irradiance.x, 0.f, 1e-6f) << wall_first;
    EXPECT_NEAR(r.ao, 1.f - mb.weight(k) / kPi, 1e-6f);
  }
  // A wall covering 0.7 of the pixel leaves 0.3 of it to the ground.
  mb.begin(V3f(0, 0, 1));
  mb.add_coverage(k, 1.0f, 1.0f, 0.7f, 0.7f * mb.weight(k), C3f(0), wall);
  mb.add_coverage(k, 0.95f, 0.95f, 0.8f, 0.8f * mb.weight(k), C3f(1), ground);
  EXPECT_NEAR(mb.resolve(0.f).irradiance.x, 0.3f * mb.weight(k), 1e-5f);
}

// A floor and a wall meeting in a corner: neither lies behind the other's
// plane, so their coverages add up as pieces of one surface do (the splats'
// overlap in one pixel makes up for a gap in the next).
TEST(Microbuffer, SurfacesSideBySideAddUp) {
  const CubeLayout& c = CubeLayout::get(8);
  Microbuffer mb(c, 0.2f);
  mb.begin(V3f(0, 0, 1));
  const uint32_t k = center_pixel(c);
  const V3f d = c.direction(k);
  // Two planes through the point at depth 1 on the ray, tilted 40 degrees
  // either way about an axis across it: a concave corner seen from inside.
  const V3f across = d.cross(V3f(1, 0, 0)).normalized();
  const float t = 0.7f;  // ~40 degrees
  const V3f na = (-d * std::cos(t) + across * std::sin(t)).normalized();
  const V3f nb = (-d * std::cos(t) - across * std::sin(t)).normalized();
  mb.add_coverage(k, 1.0f, 1.0f, 0.6f, 0.6f * mb.weight(k), C3f(1), {na, na.dot(d), 1e-3f});
  mb.add_coverage(k, 1.02f, 1.02f, 0.6f, 0.6f * mb.weight(k), C3f(2), {nb, nb.dot(d), 1e-3f});
  EXPECT_NEAR(mb.resolve(0.f).irradiance.x, 1.8f * mb.weight(k), 1e-5f);
}

TEST(Microbuffer, FragmentsBelowTheHorizonAreDropped) {
  const CubeLayout& c = CubeLayout::get(8);
  Microbuffer mb(c, 0.2f);
  mb.begin(V3f(0, 0, 1));
  const uint32_t below = c.index(5, 4, 4);  // -z face
  EXPECT_FALSE(mb.in_hemisphere(below));
  mb.add_coverage(below, 1.f, 1.f, mb.weight(below), C3f(1));
  mb.add_hit(below, 1.f, C3f(1));
  EXPECT_EQ(mb.touched_pixel_count(), 0u);
  EXPECT_EQ(mb.resolve(0.f).ao, 1.f);
}

TEST(Rasterizer, SplatOfACapGivesTheCapIrradianceAnywhere) {
  // Splats centered on the normal at random directions, including cube
  // edges and corners: the energy must not depend on where faces meet.
  std::mt19937 rng(5);
  std::normal_distribution<float> g;
  for (const uint32_t res : {4u, 8u, 32u}) {
    const CubeLayout& c = CubeLayout::get(res);
    Microbuffer mb(c, 0.2f);
    Rasterizer raster(mb);
    std::vector<V3f> dirs = {V3f(1, 1, 1).normalized(), V3f(1, 1, 0).normalized(), V3f(0, 0, 1),
                             V3f(1, 0.999f, 0.001f).normalized()};
    for (int i = 0; i < 40; ++i) dirs.push_back(V3f(g(rng), g(rng), g(rng)).normalized());
    for (const float alpha : {0.02f, 0.1f, 0.3f}) {
      for (const V3f& d : dirs) {
        mb.begin(d);
        raster.splat(d, round(cap_solid_angle(alpha)), 1.f, C3f(1));
        const Resolved r = mb.resolve(0.f);
        const float expect = cap_irradiance(alpha, 1.f);
        // A large splat is drawn as a rectangle: the cosine varies over it.
        const float tol = alpha < 0.2f ? 0.01f : 0.025f;
        EXPECT_NEAR(r.irradiance.x / expect, 1.f, tol)
            << "res " << res << " alpha " << alpha << " dir " << d;
        EXPECT_NEAR((1.f - r.ao) * kPi / expect, 1.f, tol);
      }
    }
  }
}

TEST(Rasterizer, SubPixelSplatStraddlingPixelsIsSpread) {
  const CubeLayout& c = CubeLayout::get(8);
  Microbuffer mb(c, 0.2f);
  Rasterizer raster(mb);
  mb.begin(V3f(0, 0, 1));
  // On the +z face exactly on the corner shared by four pixels.
  raster.splat(V3f(0, 0, 1), round(1e-4f), 1.f, C3f(1));
  EXPECT_EQ(mb.touched_pixel_count(), 4u);
  mb.begin(V3f(0, 0, 1));
  // Inside one pixel.
  raster.splat(V3f(0.125f, 0.125f, 1).normalized(), round(1e-4f), 1.f, C3f(1));
  EXPECT_EQ(mb.touched_pixel_count(), 1u);
}

TEST(Rasterizer, FlatSplatSeenEdgeOnStaysThin) {
  // A node seen at 84 deg from its normal, near the horizon of a floor
  // receiver: squashed vertically, it must not spill below the horizon.
  const CubeLayout& c = CubeLayout::get(8);
  Microbuffer mb(c, 0.2f);
  Rasterizer raster(mb);
  mb.begin(V3f(0, 0, 1));
  const V3f dir = V3f(1, 0.02f, 0.1f).normalized();
  Rasterizer::Shape s;
  s.omega = 0.02f * 0.1f;  // area 0.02 sr face-on, 0.1 coverage
  s.squash = V3f(0, 0, -1);
  s.ratio = 0.1f;
  s.max_radius = 0.1f;
  raster.splat(dir, s, 1.f, C3f(1));
  const Resolved r = mb.resolve(0.f);
  // All of it above the horizon: E = omega * cos(theta) within the pixel
  // center blur.
  EXPECT_NEAR(r.irradiance.x, s.omega * dir.z, 0.25f * s.omega * dir.z);
}

TEST(Rasterizer, RayCastDiskCoversItsCap) {
  // A disk of radius 1 at distance 1 facing the receiver: a 45 degree cap.
  for (const uint32_t res : {8u, 32u}) {
    const CubeLayout& c = CubeLayout::get(res);
    Microbuffer mb(c, 0.2f);
    Rasterizer raster(mb);
    mb.begin(V3f(0, 0, 1));
    const uint32_t hits = raster.raycast(V3f(0, 0, 1), V3f(0, 0, -1), 1.f, C3f(1));
    EXPECT_GT(hits, 0u);
    const Resolved r = mb.resolve(0.f);
    const float expect = cap_irradiance(kPi / 4, 1.f);
    EXPECT_NEAR(r.irradiance.x / expect, 1.f, res == 8 ? 0.15f : 0.05f) << res;
    // Seen from behind: nothing.
    mb.begin(V3f(0, 0, 1));
    EXPECT_EQ(raster.raycast(V3f(0, 0, 1), V3f(0, 0, 1), 1.f, C3f(1)), 0u);
  }
}

TEST(Rasterizer, RayCastFromInsideTheDisksSphere) {
  // Receiver 1e-3 below a large disk: nearly the whole hemisphere.
  const CubeLayout& c = CubeLayout::get(16);
  Microbuffer mb(c, 0.2f);
  Rasterizer raster(mb);
  mb.begin(V3f(0, 0, 1));
  raster.raycast(V3f(0.2f, 0, 1e-3f), V3f(0, 0, -1), 1.f, C3f(1));
  const Resolved r = mb.resolve(0.f);
  EXPECT_GT(r.irradiance.x, 0.9f * kPi);
  EXPECT_LT(r.ao, 0.1f);
}

}  // namespace
}  // namespace pbgi::gather
