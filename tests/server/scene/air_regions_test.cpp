// Air regions (server/scene/air_regions.h): a closed room's inside and the
// outside are regions apart however thin its walls; a window, or a gap
// narrower than a voxel, joins them; cutouts are no walls; points near a
// corner take the region they see, not the one beyond the wall next to them.
#include "server/scene/air_regions.h"
#include "common/errors.h"
#include "tests/server/scene/test_scenes.h"

#include <gtest/gtest.h>

namespace pbgi {
namespace {

using test::add_material;
using test::add_quad;

// The six faces of the box [lo, hi], facing in or out; `skip` leaves the
// face of that index out (0..5: -x, +x, -y, +y, -z, +z; -1: none).
void add_box(Scene& s, const V3f& lo, const V3f& hi, bool inward, uint32_t m, int skip = -1) {
  const V3f c[8] = {{lo.x, lo.y, lo.z}, {hi.x, lo.y, lo.z}, {hi.x, hi.y, lo.z}, {lo.x, hi.y, lo.z},
                    {lo.x, lo.y, hi.z}, {hi.x, lo.y, hi.z}, {hi.x, hi.y, hi.z}, {lo.x, hi.y, hi.z}};
  // Counter-clockwise seen from outside.
  const int f[6][4] = {{0, 4, 7, 3}, {1, 2, 6, 5}, {0, 1, 5, 4}, {3, 7, 6, 2}, {0, 3, 2, 1}, {4, 5, 6, 7}};
  for (int i = 0; i < 6; ++i) {
    if (i == skip) continue;
    const V3f &a = c[f[i][0]], &b = c[f[i][1]], &d = c[f[i][2]], &e = c[f[i][3]];
    if (inward) add_quad(s, a, e, d, b, m);
    else add_quad(s, a, b, d, e, m);
  }
}

// A 4 m room of two shells `t` apart standing on a 40 m ground.
Scene room(float t, int skip_inner = -1, int skip_outer = -1) {
  Scene s;
  s.source_path = "room";
  const uint32_t m = add_material(s, {0.5f, 0.5f, 0.5f});
  add_quad(s, {-20, 0, -20}, {-20, 0, 20}, {20, 0, 20}, {20, 0, -20}, m, "/ground");
  add_box(s, {-2, t, -2}, {2, 4 + t, 2}, true, m, skip_inner);
  add_box(s, {-2 - t, 0, -2 - t}, {2 + t, 4 + 2 * t, 2 + t}, false, m, skip_outer);
  return s;
}

TEST(AirRegions, AClosedRoomIsARegionApart) {
  for (const float t : {0.02f, 0.01f}) {
    const Scene s = room(t);
    const RayScene rays(s);
    const tree::RegionGrid g = build_air_regions(s, rays, 64);
    ASSERT_FALSE(g.empty());
    const uint32_t floor = locate_region(g, rays, {0, t, 0}, {0, 1, 0});
    const uint32_t ground = locate_region(g, rays, {5, 0, 5}, {0, 1, 0});
    const uint32_t outer_wall = locate_region(g, rays, {2 + t, 1, 0}, {1, 0, 0});
    EXPECT_NE(floor, tree::kAnyRegion) << t;
    EXPECT_NE(ground, tree::kAnyRegion) << t;
    EXPECT_NE(floor, ground) << t;
    EXPECT_EQ(outer_wall, ground) << t;
    // Near a corner, within a voxel (0.63 m) of two walls: the inside still.
    EXPECT_EQ(locate_region(g, rays, {1.9f, t, 1.9f}, {0, 1, 0}), floor) << t;
    EXPECT_EQ(locate_region(g, rays, {2, 3.9f + t, 1.95f}, {-1, 0, 0}), floor) << t;
    // The ground right outside the wall's foot: the outside.
    EXPECT_EQ(locate_region(g, rays, {2 + t + 0.01f, 0, 0}, {0, 1, 0}), ground) << t;
  }
}

TEST(AirRegions, AWindowJoinsTheRoomToTheOutside) {
  // The +x wall of both shells left out: an opening of 4 m.
  const Scene s = room(0.02f, 1, 1);
  const RayScene rays(s);
  const tree::RegionGrid g = build_air_regions(s, rays, 64);
  EXPECT_EQ(locate_region(g, rays, {0, 0.02f, 0}, {0, 1, 0}), locate_region(g, rays, {5, 0, 5}, {0, 1, 0}));
}

TEST(AirRegions, AGapNarrowerThanAVoxelJoins) {
  // A closed box of one shell with a 0.1 m slit through its +x face (the
  // voxel is 0.5 m): the voxels on either side of the slit are solid, but a
  // ray between their neighbours passes.
  Scene s;
  s.source_path = "slit";
  const uint32_t m = add_material(s, {0.5f, 0.5f, 0.5f});
  add_box(s, {-2, -2, -2}, {2, 2, 2}, true, m, 1);
  // The +x face, in two parts either side of the slit z in [-0.05, 0.05]...
  // centred on a voxel's centre line (voxels are 0.5 m from -3).
  const float x = 2.f, lo = 0.f - 0.05f + 0.25f, hi = 0.f + 0.05f + 0.25f;
  add_quad(s, {x, -2, -2}, {x, 2, -2}, {x, 2, lo}, {x, -2, lo}, m);
  add_quad(s, {x, -2, hi}, {x, 2, hi}, {x, 2, 2}, {x, -2, 2}, m);
  const RayScene rays(s);
  const tree::RegionGrid g = build_air_regions(s, rays, 8);
  EXPECT_EQ(locate_region(g, rays, {0, -2, 0}, {0, 1, 0}), locate_region(g, rays, {0, 2, 0}, {0, 1, 0}));
  // The same box closed: two regions, inside and out.
  Scene closed;
  closed.source_path = "closed";
  add_material(closed, {0.5f, 0.5f, 0.5f});
  add_box(closed, {-2, -2, -2}, {2, 2, 2}, true, 0);
  add_box(closed, {-2, -2, -2}, {2, 2, 2}, false, 0);
  const RayScene closed_rays(closed);
  const tree::RegionGrid cg = build_air_regions(closed, closed_rays, 8);
  EXPECT_NE(locate_region(cg, closed_rays, {0, -2, 0}, {0, 1, 0}),
            locate_region(cg, closed_rays, {0, -2, 0}, {0, -1, 0}));
}

TEST(AirRegions, CutoutsAreNoWalls) {
  Scene s = room(0.02f);
  s.materials[0].opacity = 0.5f;  // fractional: light passes
  const RayScene rays(s);
  const tree::RegionGrid g = build_air_regions(s, rays, 64);
  EXPECT_EQ(g.region_count(), 1u);
}

TEST(AirRegions, EmptyScenesAndBadResolutions) {
  Scene empty;
  const RayScene rays(empty);
  EXPECT_TRUE(build_air_regions(empty, rays, 64).empty());
  EXPECT_EQ(locate_region(tree::RegionGrid(), rays, {0, 0, 0}, {0, 1, 0}), tree::kAnyRegion);
  EXPECT_THROW(build_air_regions(empty, rays, 4), InvalidArgument);
}

}  // namespace
}  // namespace pbgi
