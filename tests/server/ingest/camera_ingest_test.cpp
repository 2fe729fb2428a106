// Cameras: UsdGeom.Camera aperture offsets and clipping range through the
// reader, their effect on camera_ray, and auto_camera's framing.
#include "server/ingest/usd_ingest.h"
#include "server/scene/auto_camera.h"
#include "server/scene/camera_rays.h"

#include "common/errors.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <fstream>

namespace pbgi {
namespace {

namespace fs = std::filesystem;

fs::path write_scene(const std::string& name, const std::string& text) {
  const fs::path dir = fs::temp_directory_path() / ("pbgi_camera_ingest_test_" + std::to_string(getpid()));
  fs::create_directories(dir);
  std::ofstream(dir / name) << text;
  return dir / name;
}

TEST(CameraIngest, OffsetsAndClippingAreRead) {
  const fs::path path = write_scene("camera.usda", R"(#usda 1.0
def Camera "Shifted"
{
    float focalLength = 35
    float horizontalAperture = 36
    float verticalAperture = 24
    float horizontalApertureOffset = 3
    float verticalApertureOffset = -2
    float2 clippingRange = (0.5, 40)
    double3 xformOp:translate = (0, 0, 10)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def Camera "Defaults"
{
}
def Camera "BadClip"
{
    float2 clippingRange = (5, 1)
}
)");
  const Scene s = read_usd_scene(path, IngestOptions{});
  const Camera* c = s.find_camera("/Shifted");
  ASSERT_NE(c, nullptr);
  EXPECT_FLOAT_EQ(c->horizontal_aperture_offset, 3.f);
  EXPECT_FLOAT_EQ(c->vertical_aperture_offset, -2.f);
  EXPECT_FLOAT_EQ(c->near_clip, 0.5f);
  EXPECT_FLOAT_EQ(c->far_clip, 40.f);
  for (const std::string& w : s.warnings) EXPECT_EQ(w.find("offset"), std::string::npos) << w;

  // USD's fallbacks: no offsets, clippingRange (1, 1000000).
  const Camera* d = s.find_camera("/Defaults");
  ASSERT_NE(d, nullptr);
  EXPECT_EQ(d->horizontal_aperture_offset, 0.f);
  EXPECT_FLOAT_EQ(d->near_clip, 1.f);
  EXPECT_FLOAT_EQ(d->far_clip, 1e6f);

  // An inverted range is a warning naming the camera, and the defaults.
  const Camera* bad = s.find_camera("/BadClip");
  ASSERT_NE(bad, nullptr);
  EXPECT_FLOAT_EQ(bad->near_clip, 0.01f);
  EXPECT_EQ(std::count_if(s.warnings.begin(), s.warnings.end(),
                          [](const std::string& w) { return w.rfind("/BadClip: clipping range", 0) == 0; }),
            1);

  // The image centre looks through the film point (3, -2) mm.
  const Ray centre = camera_ray(*c, 300, 200, 150.f, 100.f);
  EXPECT_NEAR(centre.direction.x / -centre.direction.z, 3.f / 35.f, 1e-6f);
  EXPECT_NEAR(centre.direction.y / -centre.direction.z, -2.f / 35.f, 1e-6f);
  // Clipping planes at depth 0.5 and 40: distances along the slanted ray.
  EXPECT_NEAR(centre.tmin * -centre.direction.z, 0.5f, 1e-5f);
  EXPECT_NEAR(centre.tmax * -centre.direction.z, 40.f, 1e-3f);
}

// Projects a world point with `c` into pixel coordinates (fit horizontal, as
// camera_ray does); returns false behind the camera.
bool project(const Camera& c, const V3f& p, float width, float height, V2f* pixel) {
  V3f local;
  c.local_to_world.inverse().multVecMatrix(p, local);
  if (local.z >= 0.f) return false;
  const float film_w = c.horizontal_aperture, film_h = c.horizontal_aperture * height / width;
  const float x = local.x / -local.z * c.focal_length, y = local.y / -local.z * c.focal_length;
  *pixel = V2f((x / film_w + 0.5f) * width, (0.5f - y / film_h) * height);
  return true;
}

void expect_frames(const Camera& c, const Box3f& b, float width, float height) {
  for (int k = 0; k < 8; ++k) {
    const V3f corner((k & 1) ? b.max.x : b.min.x, (k & 2) ? b.max.y : b.min.y, (k & 4) ? b.max.z : b.min.z);
    V2f px;
    ASSERT_TRUE(project(c, corner, width, height, &px)) << k;
    EXPECT_GE(px.x, 0.f);
    EXPECT_LE(px.x, width);
    EXPECT_GE(px.y, 0.f);
    EXPECT_LE(px.y, height);
    V3f local;
    c.local_to_world.inverse().multVecMatrix(corner, local);
    EXPECT_GT(-local.z, c.near_clip);
    EXPECT_LT(-local.z, c.far_clip);
  }
  // Not absurdly far: the bounds' centre-to-corner span covers a fair part
  // of the image (the sphere fits the narrow side with 10% margin).
  V2f a;
  ASSERT_TRUE(project(c, b.center(), width, height, &a));
  EXPECT_NEAR(a.x, width / 2, 1e-2f * width);
  EXPECT_NEAR(a.y, height / 2, 1e-2f * height);
}

TEST(AutoCamera, FramesTheBoundsFromTheDocumentedDirection) {
  const Box3f box(V3f(-1.f, 0.f, -3.f), V3f(5.f, 2.f, 1.f));
  for (float aspect : {1.f, 16.f / 9.f, 0.5f}) {
    const Camera c = auto_camera(box, "Y", aspect);
    EXPECT_EQ(c.prim_path, "auto");
    EXPECT_NEAR(c.horizontal_aperture / c.vertical_aperture, aspect, 1e-5f);
    expect_frames(c, box, 400.f * aspect, 400.f);
    // Y up: the eye is on the +Z side, above the centre, toward +X.
    const V3f eye(c.local_to_world[3][0], c.local_to_world[3][1], c.local_to_world[3][2]);
    const V3f back = (eye - box.center()).normalized();
    EXPECT_NEAR(std::asin(back.y) * 180.f / float(M_PI), kAutoCameraElevationDegrees, 1e-3f);
    EXPECT_NEAR(std::atan2(back.x, back.z) * 180.f / float(M_PI), kAutoCameraAzimuthDegrees, 1e-3f);
    // The camera's +Y is world up (no roll).
    EXPECT_GT(c.local_to_world[1][1], 0.f);
    EXPECT_NEAR(c.local_to_world[0][1], 0.f, 1e-6f);
  }
}

TEST(AutoCamera, ZUpStagesGetTheSameView) {
  const Box3f box(V3f(-1.f, -1.f, 0.f), V3f(1.f, 1.f, 4.f));
  const Camera c = auto_camera(box, "Z", 1.5f);
  expect_frames(c, box, 600.f, 400.f);
  const V3f eye(c.local_to_world[3][0], c.local_to_world[3][1], c.local_to_world[3][2]);
  EXPECT_GT(eye.z, box.center().z);  // above
  EXPECT_LT(eye.y, 0.f);              // in front: -Y
  EXPECT_GT(c.local_to_world[1][2], 0.f);  // camera up is +Z
}

TEST(AutoCamera, SceneWithoutGeometryAndBadAspect) {
  Scene empty;
  const Camera c = auto_camera(empty, 1.f);
  EXPECT_TRUE(std::isfinite(c.local_to_world[3][0] + c.local_to_world[3][1] + c.local_to_world[3][2]));
  EXPECT_GT(c.far_clip, c.near_clip);
  EXPECT_THROW(auto_camera(empty, 0.f), InvalidArgument);
  EXPECT_THROW(auto_camera(empty, std::nanf("")), InvalidArgument);
}

}  // namespace
}  // namespace pbgi
