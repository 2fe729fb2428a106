// resolve_camera: how every client names the camera of a request (a prim,
// "auto", or nothing), so that a scene without a camera renders with no flag.
#include "server/scene/auto_camera.h"
#include "common/errors.h"
#include "tests/server/scene/test_scenes.h"

#include <gtest/gtest.h>

namespace pbgi {
namespace {

Scene box_scene() {
  Scene s;
  s.source_path = "box.usda";
  const uint32_t m = test::add_material(s, {0.5f, 0.5f, 0.5f});
  test::add_square_z(s, 0, 0, 0, 2.f, m, false, "/floor");
  return s;
}

Camera named(const std::string& path) {
  Camera c;
  c.prim_path = path;
  c.focal_length = 35.f;
  return c;
}

TEST(ResolveCamera, NoCameraGivesTheAutoCameraForTheImage) {
  const Scene s = box_scene();
  for (const std::string& request : {std::string(), std::string(kAutoCameraPath)}) {
    const Camera c = resolve_camera(s, request, 2.f);
    const Camera expected = auto_camera(s, 2.f);
    EXPECT_EQ(c.prim_path, kAutoCameraPath);
    EXPECT_EQ(c.local_to_world, expected.local_to_world) << request;
    EXPECT_EQ(c.vertical_aperture, expected.vertical_aperture);  // the aspect is the image's
  }
  EXPECT_NE(resolve_camera(s, "", 2.f).vertical_aperture, resolve_camera(s, "", 1.f).vertical_aperture);
}

TEST(ResolveCamera, PrimsOnlyCameraAutoAndUnknownNames) {
  Scene s = box_scene();
  s.cameras["/A"] = named("/A");
  EXPECT_EQ(resolve_camera(s, "", 1.f).prim_path, "/A");  // the only one
  EXPECT_EQ(resolve_camera(s, "auto", 1.f).prim_path, "auto");
  s.cameras["/B"] = named("/B");
  EXPECT_EQ(resolve_camera(s, "/B", 1.f).prim_path, "/B");
  try {
    resolve_camera(s, "", 1.f);
    FAIL() << "several cameras, none named";
  } catch (const NotFound& e) {
    EXPECT_NE(std::string(e.what()).find("several cameras, pass --camera (cameras in the scene: /A, /B, auto)"),
              std::string::npos)
        << e.what();
  }
  try {
    resolve_camera(s, "/C", 1.f);
    FAIL() << "unknown camera";
  } catch (const NotFound& e) {
    EXPECT_NE(std::string(e.what()).find("box.usda: no camera '/C'"), std::string::npos) << e.what();
  }
  // A camera prim called "auto" wins over the auto framing.
  s.cameras["auto"] = named("auto");
  EXPECT_EQ(resolve_camera(s, "auto", 1.f).focal_length, 35.f);
  EXPECT_THROW(resolve_camera(box_scene(), "", 0.f), InvalidArgument);
}

}  // namespace
}  // namespace pbgi
