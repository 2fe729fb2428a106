#include "server/gather/cube_layout.h"
#include "common/errors.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace pbgi::gather {
namespace {

constexpr double kPi = 3.14159265358979323846;

TEST(CubeLayout, SolidAnglesSumToTheSphere) {
  for (const uint32_t n : {4u, 7u, 8u, 32u}) {
    const CubeLayout& c = CubeLayout::get(n);
    double sum = 0;
    for (uint32_t k = 0; k < c.pixel_count(); ++k) sum += c.solid_angle(k);
    EXPECT_NEAR(sum, 4 * kPi, 1e-4) << n;
  }
  EXPECT_NEAR(CubeLayout::rect_solid_angle(-1, -1, 1, 1), 4 * kPi / 6, 1e-12);
  // A small texel: ~ area / (1 + u^2 + v^2)^(3/2).
  const double u = 0.5, v = -0.3, h = 1e-3;
  EXPECT_NEAR(CubeLayout::rect_solid_angle(u, v, u + h, v + h) / (h * h),
              std::pow(1 + (u + h / 2) * (u + h / 2) + (v + h / 2) * (v + h / 2), -1.5), 1e-5);
}

TEST(CubeLayout, DirectionsAreUnitAndOnTheirFace) {
  const CubeLayout& c = CubeLayout::get(8);
  for (int f = 0; f < 6; ++f) {
    for (uint32_t j = 0; j < 8; ++j) {
      for (uint32_t i = 0; i < 8; ++i) {
        const Imath::V3f d = c.direction(c.index(f, i, j));
        EXPECT_NEAR(d.length(), 1.f, 1e-6f);
        float u, v, w;
        CubeLayout::face_coords(f, d, u, v, w);
        EXPECT_GT(w, 0.f);
        EXPECT_NEAR(u / w, -1.f + (i + 0.5f) * 0.25f, 1e-5f);
        EXPECT_NEAR(v / w, -1.f + (j + 0.5f) * 0.25f, 1e-5f);
      }
    }
  }
}

TEST(CubeLayout, MeanDirectionsGiveExactCosineIntegral) {
  // For a normal along a cube axis no pixel straddles the horizon, so the
  // weights sum to exactly the cosine integral, pi.
  for (const uint32_t n : {4u, 8u, 16u}) {
    const CubeLayout& c = CubeLayout::get(n);
    for (int axis = 0; axis < 3; ++axis) {
      double sum = 0;
      for (uint32_t k = 0; k < c.pixel_count(); ++k) {
        const float m[3] = {c.mean_dir_x()[k], c.mean_dir_y()[k], c.mean_dir_z()[k]};
        sum += std::max(0.f, m[axis]) * c.solid_angle(k);
      }
      EXPECT_NEAR(sum, kPi, 2e-5) << "resolution " << n << " axis " << axis;
    }
  }
}

TEST(CubeLayout, ConePixelsHoldEveryPixelCenterInTheCone) {
  const CubeLayout& c = CubeLayout::get(8);
  std::mt19937 rng(3);
  std::normal_distribution<float> g;
  std::uniform_real_distribution<float> u(0.01f, 1.4f);
  for (int t = 0; t < 500; ++t) {
    Imath::V3f axis(g(rng), g(rng), g(rng));
    axis.normalize();
    const float a = u(rng);
    const float sin_a = std::sin(a), cos_a = std::cos(a);
    for (int f = 0; f < 6; ++f) {
      PixelRect r;
      const bool any = c.cone_pixels(f, axis, sin_a, cos_a, r);
      for (uint32_t j = 0; j < 8; ++j) {
        for (uint32_t i = 0; i < 8; ++i) {
          if (c.direction(c.index(f, i, j)).dot(axis) < cos_a + 1e-4f) continue;
          ASSERT_TRUE(any) << "trial " << t << " face " << f;
          EXPECT_TRUE(i >= r.i0 && i <= r.i1 && j >= r.j0 && j <= r.j1)
              << "trial " << t << " face " << f << " pixel " << i << "," << j;
        }
      }
    }
  }
}

TEST(CubeLayout, ResolutionOutOfRangeThrows) {
  EXPECT_THROW(CubeLayout::get(3), InvalidArgument);
  EXPECT_THROW(CubeLayout::get(65), InvalidArgument);  // 33..64: glossy refinement
  EXPECT_EQ(&CubeLayout::get(8), &CubeLayout::get(8));
}

TEST(CubeLayout, PixelOfAPixelsDirectionIsThatPixel) {
  for (const uint32_t n : {4u, 8u, 13u, 64u}) {
    const CubeLayout& c = CubeLayout::get(n);
    for (uint32_t k = 0; k < c.pixel_count(); ++k) {
      ASSERT_EQ(c.pixel_of(c.direction(k)), k) << "N = " << n;
      ASSERT_EQ(c.pixel_of(3.f * c.direction(k)), k) << "N = " << n << ", not unit";
    }
  }
}

}  // namespace
}  // namespace pbgi::gather
