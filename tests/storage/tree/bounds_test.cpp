// Spheres, cones and options: the building blocks of the tree.
#include "common/errors.h"
#include "storage/tree/bounding_sphere.h"
#include "storage/tree/build_options.h"
#include "storage/tree/normal_cone.h"
#include "tests/storage/tree/random_surfels.h"

#include <gtest/gtest.h>

#include <cmath>

namespace pbgi::tree {
namespace {

TEST(BoundingSphere, EnclosesTiltedDisksNotOnlyCenters) {
  // Two disks facing +x at x = +-1 with radius 0.5: their rims reach
  // y, z = +-0.5, so a center-only sphere (radius 1) would miss them.
  Surfel a, b;
  a.position = {1, 0, 0};
  b.position = {-1, 0, 0};
  a.normal = b.normal = {1, 0, 0};
  a.radius = b.radius = 0.5f;
  const Surfel both[] = {a, b};
  const Sphere s = sphere_of_disks(both);
  EXPECT_NEAR(s.radius, std::sqrt(1.25f), 1e-5f);
  EXPECT_GE(s.radius, std::sqrt(1.25f));
  EXPECT_NEAR(s.center.length(), 0.f, 1e-6f);
}

TEST(BoundingSphere, MergeIsMinimalAndContainsBoth) {
  const Sphere a{{0, 0, 0}, 1}, b{{4, 0, 0}, 1};
  const Sphere m = merge_spheres(a, b);
  EXPECT_NEAR(m.radius, 3.f, 1e-5f);
  EXPECT_NEAR(m.center.x, 2.f, 1e-5f);
  // One inside the other: the outer one comes back.
  const Sphere inner{{0.5f, 0, 0}, 0.25f};
  const Sphere o = merge_spheres(a, inner);
  EXPECT_EQ(o.radius, a.radius);
  EXPECT_EQ(o.center, a.center);
}

TEST(NormalCone, SingleNormalAndOpposites) {
  Surfel s;
  s.position = {0, 0, 0};
  s.normal = {0, 0, 1};
  const Surfel one[] = {s};
  const NormalCone c = cone_of_normals(one);
  EXPECT_GT(c.cos_half_angle, 0.9999f);
  EXPECT_NEAR(c.axis.z, 1.f, 1e-6f);

  Surfel t = s;
  t.normal = {0, 0, -1};
  const Surfel two[] = {s, t};
  EXPECT_TRUE(cone_of_normals(two).is_wide());

  // Merging two narrow cones pointing opposite ways gives a cone of half
  // angle ~90 degrees around some perpendicular axis, which still contains both.
  const NormalCone up{{0, 0, 1}, 1.f}, down{{0, 0, -1}, 1.f};
  const NormalCone m = merge_cones(up, down);
  ASSERT_FALSE(m.is_wide());
  EXPECT_GE(m.axis.dot({0, 0, 1}), m.cos_half_angle - 1e-6f);
  EXPECT_GE(m.axis.dot({0, 0, -1}), m.cos_half_angle - 1e-6f);
}

TEST(NormalCone, MergeContainsBothCones) {
  std::mt19937 rng(7);
  std::normal_distribution<float> g;
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  for (int trial = 0; trial < 2000; ++trial) {
    NormalCone a{Imath::V3f(g(rng), g(rng), g(rng)).normalized(), u(rng)};
    NormalCone b{Imath::V3f(g(rng), g(rng), g(rng)).normalized(), u(rng)};
    const NormalCone m = merge_cones(a, b);
    if (m.is_wide()) continue;
    // Every direction of a and b: check the boundary at 16 azimuths.
    for (const NormalCone& c : {a, b}) {
      const Imath::V3f t = std::abs(c.axis.x) < 0.9f ? Imath::V3f(1, 0, 0) : Imath::V3f(0, 1, 0);
      const Imath::V3f e1 = c.axis.cross(t).normalized(), e2 = c.axis.cross(e1);
      const float sin_h = std::sqrt(std::max(0.f, 1 - c.cos_half_angle * c.cos_half_angle));
      for (int k = 0; k < 16; ++k) {
        const float phi = 2 * 3.14159265f * k / 16;
        const Imath::V3f d = c.axis * c.cos_half_angle + (e1 * std::cos(phi) + e2 * std::sin(phi)) * sin_h;
        ASSERT_GE(m.axis.dot(d.normalized()), m.cos_half_angle - 1e-5f) << "trial " << trial;
      }
    }
  }
}

TEST(BuildOptions, ValidateNamesTheField) {
  BuildOptions o;
  EXPECT_NO_THROW(o.validate());
  o.leaf_size = 0;
  try {
    o.validate();
    FAIL() << "leaf_size 0 accepted";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("leaf_size"), std::string::npos);
  }
  o.leaf_size = 64;
  o.page_size = 1024;  // cannot hold a 64-surfel leaf
  try {
    o.validate();
    FAIL() << "page too small for a leaf accepted";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("page_size"), std::string::npos);
  }
}

}  // namespace
}  // namespace pbgi::tree
