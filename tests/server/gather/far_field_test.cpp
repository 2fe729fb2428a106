// FarBuffer::resolve (far_field.h): a pixel's depth clusters, with rule 3's
// trimming of surfaces that lie behind the plane of one in front.
#include "server/gather/far_field.h"

#include <gtest/gtest.h>

#include <cmath>

namespace pbgi::gather {
namespace {

// A plane facing the receiver (at the origin) across pixel k's direction,
// which the pixel's centre ray meets at `depth`.
FragmentSurface facing(const Imath::V3f& dir, float depth) {
  FragmentSurface s;
  s.n = -dir;
  s.plane = -depth;
  s.tolerance = 0.01f;
  return s;
}

// Three surfaces in one depth cluster (depth band 10%): A on [1, 2] at
// 1.5, B on [2, 5] at 4.9 and C on [4.5, 4.6] at 4.55. The cluster is
// {A, B, C} in order of their near depths (B bridges A to C); trimming
// sorts them by where the ray meets their planes (A, C, B). The cluster
// was then re-walked in that order and stopped after A (C starts beyond
// A's far end), so B and C formed a second cluster, trimmed a second time:
// a fragment trimmed to nothing once then divided 0 by 0 (NaN irradiance
// in whole FPBGI receiver clusters of the city street).
TEST(FarBuffer, AClusterTrimmedByItsSurfacesIsResolvedWhole) {
  const CubeLayout& layout = CubeLayout::get(8);
  FarBuffer far(layout, 0.1f);
  const uint32_t k = 5;
  const Imath::V3f dir = layout.direction(k);
  far.begin();
  const SurfaceId a = far.add_surface(facing(dir, 1.5f));
  const SurfaceId b = far.add_surface(facing(dir, 4.9f));
  const SurfaceId c = far.add_surface(facing(dir, 4.55f));
  far.add(k, 1.f, 2.f, 0.6f, 0.01f, dir, Imath::C3f(1, 0, 0), a);
  far.add(k, 2.f, 5.f, 0.5f, 0.01f, dir, Imath::C3f(0, 1, 0), b);
  far.add(k, 4.5f, 4.6f, 0.3f, 0.01f, dir, Imath::C3f(0, 0, 1), c);
  far.resolve(0.f);
  const FarPixel& p = far.pixel(k);
  // One cluster: A whole, C whole (A leaves 0.4 of the pixel), B over the
  // 0.1 left (a fifth of its 0.5); each sends omega L, scaled as trimmed.
  EXPECT_NEAR(p.front_alpha, 1.f, 1e-5f);
  EXPECT_NEAR(p.front.r, 0.01f, 1e-7f);
  EXPECT_NEAR(p.front.b, 0.01f, 1e-7f);
  EXPECT_NEAR(p.front.g, 0.2f * 0.01f, 1e-7f);
  EXPECT_EQ(p.rest_alpha, 0.f);
  EXPECT_EQ(p.rest.occ, 0.f);
  EXPECT_TRUE(std::isfinite(p.front.r + p.front.g + p.front.b + p.rest.r + p.rest.g + p.rest.b));
}

}  // namespace
}  // namespace pbgi::gather
