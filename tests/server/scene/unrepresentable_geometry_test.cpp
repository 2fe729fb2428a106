// Geometry floats cannot hold where it lies (server/scene/
// unrepresentable_geometry.h), through rebase_to_local_frame(): tiny
// triangles and instances far beyond the bulk are dropped with one warning
// per prim; what floats still hold far away, and degenerate input within
// the bulk, stay; the soup and the instances stay consistent.
#include "server/scene/render_origin.h"
#include "server/scene/unrepresentable_geometry.h"
#include "tests/server/scene/instanced_scenes.h"
#include "tests/server/scene/test_scenes.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <string>

namespace pbgi {
namespace {

size_t warnings_naming(const Scene& s, const std::string& prim) {
  return size_t(std::count_if(s.warnings.begin(), s.warnings.end(),
                              [&](const std::string& w) { return w.rfind(prim + ":", 0) == 0; }));
}

TEST(UnrepresentableGeometry, TinyFarTrianglesAreDroppedNamingTheirPrim) {
  Scene s = test::small_room();
  const size_t room_triangles = s.triangles.triangle_count();
  // 1 unit at 1e10 is a thousandth of a float step: in float world
  // coordinates its corners already coincide.
  test::add_triangle(s, V3f(1e10f), V3f(1e10f + 1.f, 1e10f, 1e10f), V3f(1e10f, 1e10f + 1.f, 1e10f), "/Far");
  // 0.25 units at 1e5 is 32 float steps: kept (and 0.3% of the area: not
  // part of the bulk).
  test::add_triangle(s, V3f(1e5f), V3f(1e5f + 0.25f, 1e5f, 1e5f), V3f(1e5f, 1e5f + 0.25f, 1e5f), "/Distant");
  const LocalFrame frame = rebase_to_local_frame(s);
  EXPECT_TRUE(frame.outliers);
  EXPECT_EQ(frame.dropped.triangles, 1u);
  EXPECT_EQ(frame.dropped.instances, 0u);
  EXPECT_EQ(warnings_naming(s, "/Far"), 1u);
  EXPECT_EQ(warnings_naming(s, "/Distant"), 0u);
  EXPECT_EQ(s.warnings.size(), 1u);
  // The room's origin is the room's centre, not halfway to 1e10.
  EXPECT_EQ(frame.origin, V3d(0.0));
  // The soup stays consistent, and its vertices are gone with it.
  const TriangleSoup& t = s.triangles;
  ASSERT_EQ(t.triangle_count(), room_triangles + 1);
  EXPECT_EQ(t.material.size(), t.triangle_count());
  EXPECT_EQ(t.mesh.size(), t.triangle_count());
  EXPECT_EQ(t.positions.size(), 4 * 3 + 3u);
  EXPECT_LT(s.bounds().max.x, 2e5f);
  EXPECT_EQ(TriangleRef({&t, uint32_t(room_triangles), nullptr}).mesh_path(), "/Distant");
  EXPECT_EQ(to_world(s, s.triangle(uint32_t(room_triangles)).position(1)), V3d(1e5 + 0.25, 1e5, 1e5));
}

TEST(UnrepresentableGeometry, DegenerateTrianglesWithinTheBulkAreInputNotPrecisionLoss) {
  Scene s = test::small_room();
  test::add_triangle(s, V3f(0.5f), V3f(0.5f), V3f(0.5f), "/Point");
  const LocalFrame frame = rebase_to_local_frame(s);
  EXPECT_FALSE(frame.dropped.any());
  EXPECT_TRUE(s.warnings.empty());
}

TEST(UnrepresentableGeometry, FarInstancesAreDroppedAndTheRestRenumbered) {
  Scene s = test::instanced_scene();
  const Scene near = s;
  s.instances.insert(s.instances.begin() + 1, s.instances[0]);  // placed far below, renumbered next
  s.instances[1].local_to_world.setTranslation(V3f(0, 0, 1e12f));
  const LocalFrame frame = rebase_to_local_frame(s);
  EXPECT_EQ(frame.dropped.instances, 1u);
  EXPECT_EQ(warnings_naming(s, "/Proto"), 1u);
  ASSERT_EQ(s.instances.size(), near.instances.size());
  EXPECT_EQ(s.triangle_count(), near.triangle_count());
  EXPECT_EQ(s.mesh_count(), near.mesh_count());
  for (size_t k = 0; k < s.instances.size(); ++k) {
    EXPECT_EQ(s.instances[k].first_triangle, near.instances[k].first_triangle);
    EXPECT_EQ(s.instances[k].first_mesh, near.instances[k].first_mesh);
  }
}

TEST(UnrepresentableGeometry, WarningsStopAfterAFewPrims) {
  Scene s = test::small_room();
  const size_t prims = kMaxPrecisionWarnings + 4;
  for (size_t i = 0; i < prims; ++i) {
    const float x = 1e10f * float(i + 1);
    test::add_triangle(s, V3f(x, 0, 0), V3f(x + 1.f, 0, 0), V3f(x, 1.f, 0), "/Far" + std::to_string(i));
  }
  const LocalFrame frame = rebase_to_local_frame(s);
  EXPECT_EQ(frame.dropped.triangles, prims);
  ASSERT_EQ(s.warnings.size(), kMaxPrecisionWarnings + 1);
  EXPECT_EQ(warnings_naming(s, "/Far0"), 1u);
  EXPECT_NE(s.warnings.back().find("4 more prims"), std::string::npos) << s.warnings.back();
}

}  // namespace
}  // namespace pbgi
