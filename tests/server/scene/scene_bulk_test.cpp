// The bulk of a scene (server/scene/scene_bulk.h): without far outliers it
// is the scene's bounds bit for bit; a tiny triangle or an instance far
// away lies apart; a large far object is bulk.
#include "server/scene/scene_bulk.h"
#include "tests/server/scene/instanced_scenes.h"
#include "tests/server/scene/test_scenes.h"

#include <gtest/gtest.h>

namespace pbgi {
namespace {

void add_small_triangle(Scene& s, const V3f& at, float size, const std::string& path) {
  test::add_triangle(s, at, at + V3f(size, 0, 0), at + V3f(0, size, 0), path);
}

TEST(SceneBulk, WithoutOutliersIsTheScenesBounds) {
  for (const Scene& s : {test::small_room(), test::instanced_scene()}) {
    const SceneBulk bulk = scene_bulk(s);
    EXPECT_FALSE(bulk.has_outliers());
    EXPECT_EQ(bulk.bounds.min, s.bounds().min);
    EXPECT_EQ(bulk.bounds.max, s.bounds().max);
  }
}

TEST(SceneBulk, TinyFarTriangleLiesApart) {
  Scene s = test::small_room();
  const Box3f room = s.bounds();
  add_small_triangle(s, V3f(1e5f, 0.f, 0.f), 0.25f, "/Far");
  const SceneBulk bulk = scene_bulk(s);
  EXPECT_EQ(bulk.outlying_triangles, 1u);
  EXPECT_FLOAT_EQ(bulk.outlying_extent, 0.25f);
  EXPECT_EQ(bulk.bounds.min, room.min);
  EXPECT_EQ(bulk.bounds.max, room.max);
}

TEST(SceneBulk, LargeFarObjectIsBulk) {
  // 14% of the area, 1e5 away: part of the scene, not an outlier.
  Scene s = test::small_room();
  test::add_square_z(s, 1e5f, 0.f, 0.f, 0.7f, 0, false, "/FarWall");
  const SceneBulk bulk = scene_bulk(s);
  EXPECT_FALSE(bulk.has_outliers());
  EXPECT_EQ(bulk.bounds.max, s.bounds().max);
}

TEST(SceneBulk, FarInstanceLiesApart) {
  Scene s = test::instanced_scene();
  const Box3f near = s.bounds();
  s.add_instance(0, test::placement(0.3f, V3f(1.f), V3f(0, 0, 1e7f)));
  const SceneBulk bulk = scene_bulk(s);
  EXPECT_EQ(bulk.outlying_triangles, s.prototypes[0].triangles.triangle_count());
  EXPECT_GT(bulk.outlying_extent, 0.5f);
  EXPECT_LT(bulk.outlying_extent, 2.f);
  EXPECT_EQ(bulk.bounds.min, near.min);
  EXPECT_EQ(bulk.bounds.max, near.max);
}

}  // namespace
}  // namespace pbgi
