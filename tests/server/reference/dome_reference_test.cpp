// The reference path tracer with DomeLights (escaped rays, NEE + MIS) and
// textured albedo.
#include "server/reference/path_tracer.h"
#include "server/scene/environment_map.h"
#include "server/scene/texture.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>

namespace pbgi {
namespace {

// A 2x2 plane in y = 0 facing +Y, st = ((x + 1) / 2, (z + 1) / 2).
Scene plane_scene(const C3f& albedo) {
  Scene s;
  s.source_path = "<dome test>";
  Material m;
  m.albedo = albedo;
  s.materials = {m};
  TriangleSoup& t = s.triangles;
  t.positions = {V3f(-1, 0, -1), V3f(-1, 0, 1), V3f(1, 0, 1), V3f(1, 0, -1)};
  for (const V3f& p : t.positions) t.uvs.push_back(V2f((p.x + 1) / 2, (p.z + 1) / 2));
  t.indices = {0, 1, 2, 0, 2, 3};
  t.material = {0, 0};
  t.mesh = {0, 0};
  t.mesh_paths = {"/Plane"};
  t.double_sided = {0};
  return s;
}

Light constant_dome(const C3f& radiance) {
  Light l;
  l.prim_path = "/Sky";
  l.kind = LightKind::Dome;
  l.radiance = radiance;
  return l;
}

// Looking straight down (-Y) from `eye`, or up.
Camera vertical_camera(const V3f& eye, bool down, float focal_length = 50.f) {
  Camera c;
  c.prim_path = "/Camera";
  c.local_to_world = down ? M44f(1, 0, 0, 0, 0, 0, -1, 0, 0, 1, 0, 0, eye.x, eye.y, eye.z, 1)
                          : M44f(1, 0, 0, 0, 0, 0, 1, 0, 0, -1, 0, 0, eye.x, eye.y, eye.z, 1);
  c.focal_length = focal_length;
  return c;
}

ReferenceOptions options(uint32_t size, uint32_t spp) {
  ReferenceOptions o;
  o.width = o.height = size;
  o.spp = spp;
  o.tile_size = 4;
  return o;
}

double mean(const std::vector<float>& v, int channel) {
  double s = 0;
  for (size_t i = channel; i < v.size(); i += 3) s += v[i];
  return s / double(v.size() / 3);
}

TEST(DomeReference, PlaneUnderAConstantDomeReflectsAlbedoTimesL) {
  Scene s = plane_scene(C3f(0.5f, 0.25f, 0.75f));
  s.lights.push_back(constant_dome(C3f(2.f, 2.f, 2.f)));
  const RayScene rays(s);
  const ReferenceImage img = render_reference(rays, vertical_camera(V3f(0, 1, 0), true), options(8, 64));
  // E = pi L, reflected albedo / pi * E: only the plane's own underside
  // hides the dome (indirect is zero: nothing else reflects).
  EXPECT_NEAR(mean(img.direct, 0), 1.0, 0.02);
  EXPECT_NEAR(mean(img.direct, 1), 0.5, 0.01);
  EXPECT_NEAR(mean(img.direct, 2), 1.5, 0.03);
  EXPECT_EQ(mean(img.indirect, 0), 0.0);
}

TEST(DomeReference, EscapingCameraRaysSeeTheMap) {
  // A map that is 3 on its upper half and 1 below: looking up sees 3.
  std::vector<C3f> t(16 * 8, C3f(1.f));
  for (size_t i = 0; i < 16 * 4; ++i) t[i] = C3f(3.f);
  Scene s = plane_scene(C3f(0.5f, 0.5f, 0.5f));
  Light sky = constant_dome(C3f(1.f, 1.f, 1.f));
  sky.environment = std::make_shared<const EnvironmentMap>("halves", 16, 8, std::move(t));
  s.lights.push_back(sky);
  const RayScene rays(s);
  const ReferenceImage up = render_reference(rays, vertical_camera(V3f(0, 1, 0), false), options(4, 4));
  for (size_t i = 0; i < up.direct.size(); ++i) EXPECT_FLOAT_EQ(up.direct[i], 3.f);
  for (float a : up.albedo) EXPECT_EQ(a, 0.f);
  // Looking down at the plane: E = pi * 3 (upper half only), reflected 1.5.
  const ReferenceImage down = render_reference(rays, vertical_camera(V3f(0, 1, 0), true), options(8, 64));
  EXPECT_NEAR(mean(down.direct, 1), 1.5, 0.03);
}

TEST(DomeReference, AlbedoAovFollowsTheTexture) {
  Scene s = plane_scene(C3f(0.5f, 0.5f, 0.5f));
  // 2x2 texture: top row (t near 1, z > 0) 0.9, bottom row 0.1.
  TextureBinding& b = s.materials[0].albedo_texture;
  b.texture = std::make_shared<const Texture>("rows", 2, 2, 1, std::vector<float>{0.9f, 0.9f, 0.1f, 0.1f});
  b.wrap_s = b.wrap_t = TextureWrap::Clamp;
  s.lights.push_back(constant_dome(C3f(1.f, 1.f, 1.f)));
  const RayScene rays(s);
  // The camera's local +Y is world -Z: the top of the image sees z < 0,
  // t < 0.5 (0.1). A wide lens (half-width 0.87 at the plane) so that rows
  // 1 and 6 see z = -/+0.55, past the bilinear blend around t = 0.5.
  const ReferenceImage img = render_reference(rays, vertical_camera(V3f(0, 1, 0), true, 12.f), options(8, 4));
  const float top = img.albedo[(1 * 8 + 4) * 3], bottom = img.albedo[(6 * 8 + 4) * 3];
  EXPECT_NEAR(top, 0.1f, 0.02f);
  EXPECT_NEAR(bottom, 0.9f, 0.02f);
}

}  // namespace
}  // namespace pbgi
