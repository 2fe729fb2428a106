// Scene-local frames (server/scene/render_origin.h): the rebased scene is the
// same scene (positions, lights and cameras moved together, exactly when the
// inputs allow), its origin near its centre, and conversions round-trip.
#include "server/scene/render_origin.h"
#include "tests/server/scene/test_scenes.h"

#include <gtest/gtest.h>

namespace pbgi {
namespace {

Scene far_scene(float base) {
  Scene s;
  const uint32_t m = test::add_material(s, {0.5f, 0.5f, 0.5f});
  test::add_square_z(s, base + 0.25f, base - 1.f, base + 3.f, 1.f, m);
  s.lights.push_back(test::rect_light(base, base - 1.f, base + 4.f, 0.5f, 0.5f, {1, 1, 1}));
  Camera c;
  c.prim_path = "/Camera";
  c.local_to_world.setTranslation(V3f(base, base, base + 10.f));
  s.cameras[c.prim_path] = c;
  return s;
}

TEST(RenderOrigin, RebasingMovesEverythingTogetherAndExactly) {
  const float base = 1e5f;
  const Scene world = far_scene(base);
  Scene local = world;
  rebase_to_local_frame(local);
  // The origin: the bounds' centre (base + 0.25, base - 1, base + 3)
  // snapped to multiples of 1/8 (2^ceil(log2 2) / 16).
  EXPECT_EQ(local.render_origin, V3d(double(base) + 0.25, double(base) - 1.0, double(base) + 3.0));
  // Positions are now small, and exactly the world ones minus the origin
  // (floats near 1e5 minus a nearby origin lose nothing).
  for (size_t i = 0; i < world.triangles.positions.size(); ++i) {
    const V3f& p = local.triangles.positions[i];
    EXPECT_LE(std::abs(p.x) + std::abs(p.y) + std::abs(p.z), 2.f);
    const V3d w = to_world(local, p);
    const V3f& q = world.triangles.positions[i];
    EXPECT_EQ(w, V3d(q.x, q.y, q.z));
  }
  // Light and camera moved by the same amount; their axes untouched.
  const V3f lt = local.lights[0].local_to_world.translation();
  EXPECT_EQ(to_world(local, lt), V3d(base, double(base) - 1.0, double(base) + 4.0));
  EXPECT_EQ(to_world(local, local.cameras.at("/Camera").local_to_world.translation()),
            V3d(base, base, double(base) + 10.0));
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      EXPECT_EQ(local.lights[0].local_to_world[r][c], world.lights[0].local_to_world[r][c]);
  // Rebasing again is a no-op; rebasing back restores the world scene.
  Scene again = local;
  rebase_to_local_frame(again);
  EXPECT_EQ(again.triangles.positions, local.triangles.positions);
  rebase_scene(again, V3d(0.0));
  EXPECT_EQ(again.triangles.positions, world.triangles.positions);
  EXPECT_EQ(again.render_origin, V3d(0.0));
  // to_local inverts to_world.
  EXPECT_EQ(to_local(local, to_world(local, V3f(0.5f, -0.25f, 1.f))), V3f(0.5f, -0.25f, 1.f));
}

// One tiny triangle far away (issue 17): the frame stays at the scene's
// centre (before, it moved to the centre of the bounds, halfway to the
// outlier, where the scene collapsed into a few float steps).
TEST(RenderOrigin, AFarOutlierDoesNotMoveTheOrigin) {
  const float base = 1e5f;
  const Scene near = far_scene(base);
  for (const float outlier : {-1e5f, 1e10f, 1e20f}) {
    Scene s = near;
    const V3f o(outlier);
    test::add_quad(s, o, o + V3f(0.1f, 0, 0), o + V3f(0.1f, 0.1f, 0), o + V3f(0, 0.1f, 0), 0, "/Far");
    EXPECT_EQ(render_origin_for(s), render_origin_for(near)) << outlier;
  }
}

TEST(RenderOrigin, EmptySceneKeepsTheWorldOrigin) {
  Scene s;
  EXPECT_EQ(render_origin_for(s), V3d(0.0));
  rebase_to_local_frame(s);
  EXPECT_EQ(s.render_origin, V3d(0.0));
}

}  // namespace
}  // namespace pbgi
