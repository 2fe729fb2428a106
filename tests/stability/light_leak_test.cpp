// Light leaks through walls (issue 20): closed rooms lit from outside by a
// sun and a sky, a room lit through one window, a thin lit panel seen from
// its dark side. Inside a closed room the reference is black (no path gets
// in); PBGI's gather must not show the lit outside through the walls. Leaks
// are measured relative to the exterior level, the radiance of the open
// sunlit ground (open_ground_radiance()).
//
// What keeps them dark: air regions (storage/tree/region_grid.h,
// docs/gather.md section 11). The build finds the closed parts of the
// scene's empty space and keeps each one's surfels in a subtree of its
// own; a receiver walks its region's subtree alone, so no node mixes the
// sunlit ground outside a wall's foot with the floor inside. Without them
// (air_region_resolution 0) what leaked (2 cm shells, 0.021 of the exterior
// level) was the walls' splat coverage passing part of what lies behind
// them and, for a zero-thickness shell on the ground, ground nodes coplanar
// with the floor and straddling the wall: docs/gather.md section 10 and
// docs/measurements/2026-11-27-closed-rooms.md have the figures.
#include "client/image/exr_image.h"
#include "tests/stability/stability_harness.h"
#include "tests/stability/stability_scenes.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <string>

namespace pbgi::stability {
namespace {

void report(const std::string& what, double value, double bound, const char* kind = "bound") {
  std::printf("[ measured ] %-56s %.4g (%s %.4g)\n", what.c_str(), value, kind, bound);
  ::testing::Test::RecordProperty(what, std::to_string(value));
}

double max_value(const std::vector<float>& v) {
  return v.empty() ? 0.0 : double(*std::max_element(v.begin(), v.end()));
}

// The interior's indirect light relative to the exterior level: mean and
// brightest pixel. Direct light must not get in at all.
struct Leak {
  double mean = 0, max = 0;
};

struct RoomCase {
  const char* name;
  ClosedRoom room;
  // Without air regions (measured, 20k surfels, defaults): the bounds x 1.25
  // of LightLeak.ClosedRoomLeakWithoutAirRegions, so that the cases stay
  // as hard as they were.
  Leak without_regions;
};

const RoomCase kRooms[] = {
    {"2 cm shells", {0.02f, 2, false}, {0.0206, 0.166}},
    {"1 cm shells", {0.01f, 2, false}, {0.0211, 0.167}},
    {"1 cm shells, double-sided", {0.01f, 2, true}, {0.00619, 0.0797}},
    // Zero thickness, lying on the ground.
    {"single shell, double-sided", {0.f, 1, true}, {0.0224, 0.169}},
};
constexpr double kMargin = 1.25;

// The images measured here are leaks, near zero where they should be zero:
// no relative comparison of interpolated and per-sample gathers is
// meaningful on them (their leak figures are the bounds).
RenderSettings leak_settings() {
  RenderSettings s;
  s.interpolation_bound = 1e9;
  return s;
}

Leak inside_leak(const RoomCase& c, bool ray_depth_caps = false, bool air_regions = true, uint32_t bounces = 1) {
  const Scene scene = closed_room(c.room);
  RenderSettings settings = leak_settings();
  settings.bounces = bounces;
  settings.gather.ray_depth_caps = ray_depth_caps;
  if (!air_regions) settings.air_region_resolution = 0;
  const Aovs inside = render_pbgi(scene, "/Inside", settings);
  const double level = open_ground_radiance();
  const Leak leak{mean_value(inside.indirect) / level, max_value(inside.indirect) / level};
  EXPECT_EQ(max_value(inside.direct), 0.0) << c.name << ": direct light got in";
  const std::string name = std::string("closed room, ") + c.name + (ray_depth_caps ? ", depth caps" : "") +
                           (air_regions ? "" : ", no air regions") +
                           (bounces > 1 ? ", " + std::to_string(bounces) + " bounces" : "");
  report(name + ": interior mean / exterior", leak.mean, 1e-3, "goal");
  report(name + ": interior max / exterior", leak.max, 1e-2, "goal");
  return leak;
}

// The scene is what it claims: nothing gets in (the reference's interior
// is black), and the open ground has the exterior level.
TEST(LightLeak, ClosedRoomReferenceIsBlackInside) {
  const Scene scene = closed_room({});
  RenderSettings s;
  s.reference_spp = 64;
  EXPECT_EQ(max_value(render_path(scene, "/Inside", s).beauty), 0.0);
  const Aovs outside = render_path(scene, "/Outside", s);
  // /Outside sees only ground, partly in the room's shadow.
  const double ratio = mean_value(outside.beauty) / open_ground_radiance();
  report("closed room: outside view mean / open ground", ratio, 1.0);
  EXPECT_GT(ratio, 0.6);
  EXPECT_LT(ratio, 1.02);
}

// The goal: interior mean <= 0.1% and brightest pixel <= 1% of the
// exterior level. Measured with air regions: 0 in every case (a receiver
// inside walks only the inside's surfels).
TEST(LightLeak, ClosedRoomsStayDark) {
  for (const RoomCase& c : kRooms) {
    const Leak leak = inside_leak(c);
    EXPECT_LE(leak.mean, 1e-3) << c.name;
    EXPECT_LE(leak.max, 1e-2) << c.name;
  }
}

// With bounces built into the surfels: the bounce sets keep the direct
// set's regions, and their gathers at surfels walk only their regions.
TEST(LightLeak, ClosedRoomsStayDarkWithBounces) {
  for (const RoomCase& c : {kRooms[0], kRooms[3]}) {
    const Leak leak = inside_leak(c, false, true, 3);
    EXPECT_LE(leak.mean, 1e-3) << c.name;
    EXPECT_LE(leak.max, 1e-2) << c.name;
  }
}

// The same with the ray-traced depth caps (GatherOptions::ray_depth_caps,
// off by default): they must not bring light back in.
TEST(LightLeak, ClosedRoomsStayDarkWithRayDepthCaps) {
  for (const RoomCase& c : kRooms) {
    const Leak leak = inside_leak(c, true);
    EXPECT_LE(leak.mean, 1e-3) << c.name;
    EXPECT_LE(leak.max, 1e-2) << c.name;
  }
}

// Without air regions the rooms leak as they did (the goal above fails):
// the cases still test what they were built to.
TEST(LightLeak, ClosedRoomLeakWithoutAirRegions) {
  for (const RoomCase& c : kRooms) {
    const Leak leak = inside_leak(c, false, false);
    EXPECT_GT(leak.mean, 1e-3) << c.name;
    EXPECT_LE(leak.mean, kMargin * c.without_regions.mean) << c.name;
    EXPECT_LE(leak.max, kMargin * c.without_regions.max) << c.name;
  }
}

// The room lit from inside by a lamp under its ceiling, the sun and sky
// outside: the inside's indirect light against the path tracer's, with the
// air regions (the default) and without (the outside's light then leaks in
// and adds to the lamp's).
// Measured 0.068 (without air regions 0.82); x 1.25.
constexpr double kLitRoomBound = 0.085;

TEST(LightLeak, ClosedRoomLitFromInsideAgainstTheReference) {
  ClosedRoom lit;
  lit.lamp = true;
  const Scene scene = closed_room(lit);
  RenderSettings s = leak_settings();
  s.reference_spp = 256;
  const std::vector<float> ref = render_path(scene, "/Inside", s).indirect;
  ASSERT_GT(mean_value(ref), 0.0);
  const double with_regions = relative_rmse(render_pbgi(scene, "/Inside", s).indirect, ref);
  s.air_region_resolution = 0;
  const double without = relative_rmse(render_pbgi(scene, "/Inside", s).indirect, ref);
  report("lit room: PBGI vs path tracer, air regions", with_regions, kLitRoomBound);
  report("lit room: PBGI vs path tracer, no air regions", without, with_regions, "more than");
  EXPECT_LE(with_regions, kLitRoomBound);
  EXPECT_GT(without, with_regions);
}

// A 1 cm panel lit on one side: from the other side, the panel and the
// floor behind it get no light in the reference. Measured: PBGI's beauty
// there is 2.3e-5 of the lit side's mean on average, 9.7e-5 at the
// brightest pixel (1.1e-4 and 0.022 at the panel's foot before air
// regions: the floor strip between the panel's faces is a region of its
// own); goal: <= 1e-3 and <= 1e-2.
TEST(LightLeak, ThinLitPanelIsDarkFromBehind) {
  const Scene scene = thin_lit_panel();
  const RenderSettings s = leak_settings();
  const Aovs dark = render_pbgi(scene, "/Dark", s);
  const Aovs lit_ref = render_path(scene, "/Lit", s);
  EXPECT_EQ(max_value(render_path(scene, "/Dark", s).beauty), 0.0);
  const double level = mean_value(lit_ref.beauty);
  ASSERT_GT(level, 0.0);
  const double mean = mean_value(dark.beauty) / level, max = max_value(dark.beauty) / level;
  report("thin panel: dark side mean / lit side mean", mean, 1e-3);
  report("thin panel: dark side max / lit side mean", max, 1e-2);
  EXPECT_LE(mean, 1e-3);
  EXPECT_LE(max, 1e-2);
  EXPECT_EQ(max_value(dark.direct), 0.0);
}

// The room lit through one window (stability_scenes.h: sunlit_room) against
// a converged reference. A path-traced reference converged enough to judge
// 5% takes minutes (one at 16384 spp is itself 0.039 from the truth: two
// seeds differ by 0.055), so it is rendered once, by
//   build/tests/stability_test --gtest_also_run_disabled_tests
//       --gtest_filter='LightLeak.DISABLED_WriteWindowRoomReference'
// and stored in tests/stability/data (65536 spp, noise ~0.02: PBGI is
// 0.048 from it, ~0.044 from the truth once that noise is taken out). The test
// first checks that the stored image is still this scene's reference: a
// fresh 1024-spp render must agree with it within that render's own noise
// (measured 0.163; a changed scene or path tracer moves it beyond).
constexpr uint32_t kWindowReferenceSpp = 65536;
constexpr uint64_t kWindowReferenceSeed = 11;
constexpr double kWindowFreshReferenceBound = 0.25;

std::string window_reference_path() {
  return std::string(PBGI_TEST_SOURCE_DIR) + "/tests/stability/data/sunlit_room_indirect.exr";
}

TEST(LightLeak, DISABLED_WriteWindowRoomReference) {
  RenderSettings fine;
  fine.reference_spp = kWindowReferenceSpp;
  fine.reference_seed = kWindowReferenceSeed;
  const Aovs ref = render_path(sunlit_room(), "/Camera", fine);
  image::ExrImage img(fine.width, fine.height);
  img.set_rgb("indirect", ref.indirect);
  img.attributes()["pbgi/scene"] = "stability sunlit_room /Camera";
  img.attributes()["pbgi/spp"] = std::to_string(fine.reference_spp);
  img.attributes()["pbgi/seed"] = std::to_string(fine.reference_seed);
  img.attributes()["pbgi/max_depth"] = std::to_string(fine.reference_max_depth);
  image::write_exr(window_reference_path(), img);
}

TEST(LightLeak, RoomLitThroughOneWindowAgainstAConvergedReference) {
  const image::ExrImage stored = image::read_exr(window_reference_path());
  const RenderSettings s;
  ASSERT_EQ(stored.width(), s.width);
  ASSERT_EQ(stored.height(), s.height);
  EXPECT_EQ(stored.attributes().at("pbgi/scene"), "stability sunlit_room /Camera");
  EXPECT_EQ(stored.attributes().at("pbgi/spp"), std::to_string(kWindowReferenceSpp));
  EXPECT_EQ(stored.attributes().at("pbgi/max_depth"), std::to_string(s.reference_max_depth));
  const std::vector<float> converged = stored.rgb("indirect");

  const Scene scene = sunlit_room();
  const double fresh = relative_rmse(render_path(scene, "/Camera", s).indirect, converged);
  report("window: 1024-spp reference vs the stored one", fresh, kWindowFreshReferenceBound);
  ASSERT_LE(fresh, kWindowFreshReferenceBound)
      << "the stored reference is not this scene's any more: regenerate it (see above)";

  const double err = relative_rmse(render_pbgi(scene, "/Camera", s).indirect, converged);
  report("window: PBGI vs the 65536-spp reference", err, 0.05);
  EXPECT_LE(err, 0.05);
}

}  // namespace
}  // namespace pbgi::stability
