#include "server/scene/camera_rays.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

namespace pbgi {
namespace {

Camera test_camera() {
  Camera c;
  c.prim_path = "/cam";
  c.focal_length = 35.f;
  c.horizontal_aperture = 36.f;
  c.vertical_aperture = 24.f;
  c.local_to_world.makeIdentity();
  return c;
}

float angle(const V3f& a, const V3f& b) { return std::acos(std::clamp(a.dot(b), -1.f, 1.f)); }

TEST(CameraRays, CenterRayLooksDownMinusZ) {
  const Camera cam = test_camera();
  const Ray r = camera_ray(cam, 640, 480, 320.f, 240.f);
  EXPECT_NEAR(r.direction.x, 0.f, 1e-6f);
  EXPECT_NEAR(r.direction.y, 0.f, 1e-6f);
  EXPECT_NEAR(r.direction.z, -1.f, 1e-6f);
  EXPECT_EQ(r.origin, V3f(0, 0, 0));
}

TEST(CameraRays, CornersSpanTheFieldOfView) {
  const Camera cam = test_camera();
  const uint32_t w = 640, h = 480;
  const Ray left = camera_ray(cam, w, h, 0.f, 240.f);
  const Ray right = camera_ray(cam, w, h, 640.f, 240.f);
  const Ray top = camera_ray(cam, w, h, 320.f, 0.f);
  const Ray bottom = camera_ray(cam, w, h, 320.f, 480.f);
  const float hfov = 2.f * std::atan(18.f / 35.f);
  // Fit horizontal: the vertical film is 36 * 480/640 = 27 mm.
  const float vfov = 2.f * std::atan(13.5f / 35.f);
  EXPECT_NEAR(angle(left.direction, right.direction), hfov, 1e-5f);
  EXPECT_NEAR(angle(top.direction, bottom.direction), vfov, 1e-5f);
  EXPECT_LT(left.direction.x, 0.f);    // +X is right
  EXPECT_GT(top.direction.y, 0.f);     // y down in pixels, +Y up in camera space
  const Ray corner = camera_ray(cam, w, h, 0.f, 0.f);
  EXPECT_NEAR(corner.direction.x / -corner.direction.z, -18.f / 35.f, 1e-5f);
  EXPECT_NEAR(corner.direction.y / -corner.direction.z, 13.5f / 35.f, 1e-5f);
  EXPECT_NEAR(corner.direction.length(), 1.f, 1e-6f);
}

TEST(CameraRays, FollowsTheCameraTransform) {
  Camera cam = test_camera();
  // Camera at (1,2,3) looking down world -X (local -Z -> world -X): rows are
  // the images of local X, Y, Z, then the translation.
  cam.local_to_world = M44f(0, 0, -1, 0,  0, 1, 0, 0,  1, 0, 0, 0,  1, 2, 3, 1);
  const Ray r = camera_ray(cam, 100, 100, 50.f, 50.f);
  EXPECT_NEAR((r.origin - V3f(1, 2, 3)).length(), 0.f, 1e-6f);
  EXPECT_NEAR(r.direction.x, -1.f, 1e-6f);
  const Ray right = camera_ray(cam, 100, 100, 100.f, 50.f);
  EXPECT_LT(right.direction.z, 0.f);  // local +X is world -Z
}

}  // namespace
}  // namespace pbgi
