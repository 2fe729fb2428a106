// Light leaks through walls (issue 20): closed rooms lit from outside by a
// sun and a sky, a room lit through one window, a thin lit panel seen from
// its dark side. Inside a closed room the reference is black (no path gets
// in); PBGI's gather must not show the lit outside through the walls. Leaks
// are measured relative to the exterior level, the radiance of the open
// sunlit ground (open_ground_radiance()).
//
// Where PBGI does not meet the goal yet, the goal is a DISABLED_
// test (run with --gtest_also_run_disabled_tests) and an enabled test
// bounds today's measured value with a margin, so that it can only get
// better. What leaked most (2 cm shells, 0.062 of the exterior level
// before): the sunlit ground just behind a wall's foot, within the
// microbuffer's depth band of the wall, joined the wall's cluster and added
// its light. The microbuffer now tells surfaces apart within a cluster
// (fragment_surface.h) and hides one lying behind another's plane: 0.021.
// What is left (measured, docs/measurements/2026-11-27-light-leak-surfaces.md):
// the walls' splat coverage passing part of what lies behind them (drawing
// back faces as black occluders took the 2 cm room to 0.0043, at +27% node
// visits and +48% splats: not kept), and, for a zero-thickness shell on the
// ground, ground nodes coplanar with the floor and straddling the wall.
// Without the ground the same room leaks 8e-5: the walls' own outer faces
// are handled (two-faced nodes, back-face culling). docs/gather.md section
// 10 has the figures.
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
  Leak today;  // measured (20k surfels, defaults): the enabled test's bounds x 1.25
};

// Measured with surfaces told apart in the microbuffer (before: 0.0615 /
// 0.230, 0.0623 / 0.232, 0.0403 / 0.119, 0.116 / 1.035).
const RoomCase kRooms[] = {
    {"2 cm shells", {0.02f, 2, false}, {0.0206, 0.166}},
    {"1 cm shells", {0.01f, 2, false}, {0.0211, 0.167}},
    {"1 cm shells, double-sided", {0.01f, 2, true}, {0.00496, 0.0773}},
    // Zero thickness, lying on the ground: one pixel sees the whole
    // exterior level.
    {"single shell, double-sided", {0.f, 1, true}, {0.0893, 1.051}},
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

Leak inside_leak(const RoomCase& c) {
  const Scene scene = closed_room(c.room);
  const Aovs inside = render_pbgi(scene, "/Inside", leak_settings());
  const double level = open_ground_radiance();
  const Leak leak{mean_value(inside.indirect) / level, max_value(inside.indirect) / level};
  EXPECT_EQ(max_value(inside.direct), 0.0) << c.name << ": direct light got in";
  report(std::string("closed room, ") + c.name + ": interior mean / exterior", leak.mean, 1e-3, "goal");
  report(std::string("closed room, ") + c.name + ": interior max / exterior", leak.max, 1e-2, "goal");
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

TEST(LightLeak, ClosedRoomLeakDoesNotGrow) {
  for (const RoomCase& c : kRooms) {
    const Leak leak = inside_leak(c);
    EXPECT_LE(leak.mean, kMargin * c.today.mean) << c.name;
    EXPECT_LE(leak.max, kMargin * c.today.max) << c.name;
  }
}

// The goal: interior mean <= 0.1% and brightest pixel <= 1% of the
// exterior level. Fails today (kRooms::today).
TEST(LightLeak, DISABLED_ClosedRoomsStayDark) {
  for (const RoomCase& c : kRooms) {
    const Leak leak = inside_leak(c);
    EXPECT_LE(leak.mean, 1e-3) << c.name;
    EXPECT_LE(leak.max, 1e-2) << c.name;
  }
}

// A 1 cm panel lit on one side: from the other side, the panel and the
// floor behind it get no light in the reference. Measured: PBGI's beauty
// there is 1.1e-4 of the lit side's mean on average, 0.022 at the
// brightest pixel (at the panel's foot); goal: <= 1e-3 and <= 1e-2.
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
  report("thin panel: dark side max / lit side mean", max, 0.03);
  EXPECT_LE(mean, 1e-3);
  EXPECT_LE(max, 0.03);
  EXPECT_EQ(max_value(dark.direct), 0.0);
}

// The room lit through one window (stability_scenes.h: sunlit_room) against
// a converged reference. Stability.SunlitRoomBehindWindow's 1024-spp
// reference is itself 0.166 (relative RMSE of the indirect AOV) from a
// 16384-spp one: its bound measures mostly the reference's noise. Against
// 16384 spp PBGI is 0.058 (0.069 before surfaces were told apart in the
// microbuffer; the reference's own noise there is ~0.04); goal 0.05. Slow
// (100 s on a loaded machine, mostly the reference): disabled.
TEST(LightLeak, DISABLED_RoomLitThroughOneWindowAgainstAConvergedReference) {
  const Scene scene = sunlit_room();
  const Aovs pbgi = render_pbgi(scene, "/Camera", RenderSettings{});
  RenderSettings fine;
  fine.reference_spp = 16384;
  fine.reference_seed = 11;
  const Aovs ref = render_path(scene, "/Camera", fine);
  const double err = relative_rmse(pbgi.indirect, ref.indirect);
  report("window: PBGI vs 16384-spp reference", err, 0.05);
  EXPECT_LE(err, 0.05);
}

}  // namespace
}  // namespace pbgi::stability
