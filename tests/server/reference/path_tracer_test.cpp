#include "server/reference/path_tracer.h"

#include "common/errors.h"

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace pbgi {
namespace {

constexpr float kPiF = 3.14159265358979323846f;

// Appends the quad (a, b, c, d) as two triangles wound so that their
// geometric normal points along `facing`.
void add_quad(Scene& s, V3f a, V3f b, V3f c, V3f d, const V3f& facing, uint32_t material) {
  if ((b - a).cross(c - a).dot(facing) < 0.f) std::swap(b, d);
  const uint32_t base = uint32_t(s.triangles.positions.size());
  for (const V3f& p : {a, b, c, d}) s.triangles.positions.push_back(p);
  for (uint32_t i : {0u, 1u, 2u, 0u, 2u, 3u}) s.triangles.indices.push_back(base + i);
  for (int i = 0; i < 2; ++i) {
    s.triangles.material.push_back(material);
    s.triangles.mesh.push_back(0);
  }
}

// An axis-aligned cube of half-size h around the origin, normals inward.
void add_inward_cube(Scene& s, float h, uint32_t material) {
  for (int axis = 0; axis < 3; ++axis) {
    for (float side : {-1.f, 1.f}) {
      const int u = (axis + 1) % 3, v = (axis + 2) % 3;
      V3f corner[4];
      const float uv[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
      for (int i = 0; i < 4; ++i) {
        corner[i][axis] = side * h;
        corner[i][u] = uv[i][0] * h;
        corner[i][v] = uv[i][1] * h;
      }
      V3f inward(0, 0, 0);
      inward[axis] = -side;
      add_quad(s, corner[0], corner[1], corner[2], corner[3], inward, material);
    }
  }
}

Scene empty_scene() {
  Scene s;
  s.source_path = "<test scene>";
  s.triangles.mesh_paths = {"/Test/Mesh"};
  s.triangles.double_sided = {1};
  return s;
}

// Camera looking straight down (-Y) from `eye`, local +Y mapped to world -Z.
Camera down_camera(const V3f& eye, float focal_length) {
  Camera c;
  c.prim_path = "/Camera";
  c.local_to_world = M44f(1, 0, 0, 0, 0, 0, -1, 0, 0, 1, 0, 0, eye.x, eye.y, eye.z, 1);
  c.focal_length = focal_length;
  return c;
}

Camera origin_camera() {
  Camera c;
  c.prim_path = "/Camera";
  c.local_to_world = M44f();  // at the origin, looking down -Z
  c.focal_length = 10.f;      // wide: rays reach several faces of a box
  return c;
}

ReferenceOptions small_options(uint32_t size, uint32_t spp) {
  ReferenceOptions o;
  o.width = o.height = size;
  o.spp = spp;
  o.tile_size = 4;
  return o;
}

// White furnace: inside a closed box of albedo a and emission Le everywhere,
// radiance is Le (1 + a + a^2 + ...) = Le / (1 - a) in every direction.
// Without UsdLux lights, direct is the emission seen (Le) and all the rest
// is light from surfaces; with BSDF sampling alone indirect1 = a Le is exact
// per sample (Russian roulette starts later). With next-event estimation of
// the emissive walls (the default) the estimate is unbiased but no longer
// exact per sample: checked statistically at the end.
TEST(PathTracer, WhiteFurnaceConvergesToLeOverOneMinusAlbedo) {
  const float a = 0.6f, le = 0.5f;
  Scene s = empty_scene();
  Material m;
  m.albedo = C3f(a, a, a);
  m.emission = C3f(le, le, le);
  s.materials.push_back(m);
  add_inward_cube(s, 1.f, 0);
  const RayScene rays(s);

  ReferenceOptions o = small_options(8, 2048);
  o.pass_spp = 256;
  o.max_depth = 1000;
  o.sample_emissive_triangles = false;
  ReferenceStats stats;
  const ReferenceImage img = render_reference(rays, origin_camera(), o, {}, &stats);
  ASSERT_EQ(img.spp, 2048u);
  const float expected = le / (1.f - a);
  double mean = 0;
  for (size_t i = 0; i < img.beauty.size(); ++i) {
    EXPECT_NEAR(img.beauty[i], expected, 0.02f * expected) << "value " << i;
    EXPECT_NEAR(img.direct[i], le, 1e-5f);
    EXPECT_NEAR(img.indirect1[i], le * a, 1e-5f);
    EXPECT_NEAR(img.indirect[i], img.beauty[i] - le, 1e-5f);
    EXPECT_NEAR(img.albedo[i], a, 1e-6f);
    mean += img.beauty[i];
  }
  EXPECT_NEAR(mean / double(img.beauty.size()), expected, 0.003 * expected);
  for (float ao : img.ao) EXPECT_EQ(ao, 0.f);  // fully enclosed
  EXPECT_EQ(stats.nonfinite_samples, 0u);
  EXPECT_EQ(stats.camera_samples, 8u * 8u * 2048u);
  EXPECT_GT(stats.rays, stats.camera_samples * 3);

  // Emissive walls sampled directly and MIS-combined: the same radiance.
  o.sample_emissive_triangles = true;
  o.spp = 1024;
  const ReferenceImage nee = render_reference(rays, origin_camera(), o);
  double nee_mean = 0, nee_mean1 = 0;
  for (size_t i = 0; i < nee.beauty.size(); ++i) {
    EXPECT_NEAR(nee.beauty[i], expected, 0.03 * expected) << "value " << i;
    EXPECT_NEAR(nee.direct[i], le, 1e-5f);
    nee_mean += nee.beauty[i];
    nee_mean1 += nee.indirect1[i];
  }
  EXPECT_NEAR(nee_mean / double(nee.beauty.size()), expected, 0.005 * expected);
  EXPECT_NEAR(nee_mean1 / double(nee.beauty.size()), le * a, 0.005 * le * a);
}

// Without Russian roulette at all depths a hard max_depth cuts the series:
// max_depth = D keeps reflections k <= D, Le (1 + a + ... + a^D).
TEST(PathTracer, MaxDepthTruncatesTheSeries) {
  const float a = 0.5f, le = 1.f;
  Scene s = empty_scene();
  Material m;
  m.albedo = C3f(a, a, a);
  m.emission = C3f(le, le, le);
  s.materials.push_back(m);
  add_inward_cube(s, 1.f, 0);
  const RayScene rays(s);
  ReferenceOptions o = small_options(4, 4);
  o.max_depth = 3;
  o.rr_start_depth = 10;
  o.sample_emissive_triangles = false;  // exact per sample (see the furnace)
  const ReferenceImage img = render_reference(rays, origin_camera(), o);
  for (float v : img.beauty) EXPECT_NEAR(v, le * (1 + a + a * a + a * a * a), 1e-4f);
  o.max_depth = 1;
  const ReferenceImage direct_only = render_reference(rays, origin_camera(), o);
  for (size_t i = 0; i < direct_only.beauty.size(); ++i) {
    EXPECT_NEAR(direct_only.beauty[i], le * (1 + a), 1e-4f);
    EXPECT_NEAR(direct_only.indirect[i], le * a, 1e-4f);  // emission of x2 reflected at x1
  }
  // Next-event estimation keeps the cut where it is (in the mean).
  o.sample_emissive_triangles = true;
  o.spp = 512;
  for (const uint32_t depth : {1u, 3u}) {
    o.max_depth = depth;
    const ReferenceImage nee = render_reference(rays, origin_camera(), o);
    double mean = 0;
    for (float v : nee.beauty) mean += v / double(nee.beauty.size());
    const double expect = depth == 1 ? le * (1 + a) : le * (1 + a + a * a + a * a * a);
    EXPECT_NEAR(mean, expect, 0.005 * expect) << "max_depth " << depth;
  }
}

// A uniform "sky": a small albedo-1 plane inside a huge black emissive box
// of radiance L receives irradiance pi L, so it reflects radiance L. The sky
// is a surface, so that light is indirect (one surface: indirect1).
TEST(PathTracer, PlaneUnderUniformSkyReflectsSkyRadiance) {
  const float L = 2.f;
  Scene s = empty_scene();
  Material sky;
  sky.albedo = C3f(0, 0, 0);
  sky.emission = C3f(L, L, L);
  Material plane;
  plane.albedo = C3f(1, 1, 1);
  s.materials = {sky, plane};
  add_inward_cube(s, 1000.f, 0);
  add_quad(s, V3f(-1, 0, -1), V3f(1, 0, -1), V3f(1, 0, 1), V3f(-1, 0, 1), V3f(0, 1, 0), 1);
  const RayScene rays(s);
  // BSDF sampling alone is exact per sample here; with the sky's triangles
  // sampled directly (MIS) the mean must agree.
  ReferenceOptions exact = small_options(8, 16);
  exact.sample_emissive_triangles = false;
  const ReferenceImage img = render_reference(rays, down_camera(V3f(0, 1, 0), 50.f), exact);
  for (size_t i = 0; i < img.beauty.size(); ++i) {
    EXPECT_NEAR(img.beauty[i], L, 1e-3f * L);
    EXPECT_NEAR(img.indirect1[i], L, 1e-3f * L);
    EXPECT_EQ(img.direct[i], 0.f);
  }
  const ReferenceImage nee = render_reference(rays, down_camera(V3f(0, 1, 0), 50.f),
                                              small_options(8, 512));
  double nee_mean = 0;
  for (size_t i = 0; i < nee.beauty.size(); ++i) {
    EXPECT_NEAR(nee.beauty[i], L, 0.05f * L);
    nee_mean += nee.indirect1[i] / double(nee.beauty.size());
  }
  EXPECT_NEAR(nee_mean, L, 0.005 * L);
  for (float ao : img.ao) EXPECT_EQ(ao, 0.f);  // the sky box is geometry: it occludes
  ReferenceOptions near_ao = small_options(8, 16);
  near_ao.ao_max_distance = 10.f;
  const ReferenceImage open = render_reference(rays, down_camera(V3f(0, 1, 0), 50.f), near_ao);
  for (float ao : open.ao) EXPECT_EQ(ao, 1.f);  // ... unless farther than ao_max_distance
}

// Form factor from a point to a parallel rectangle [0,X]x[0,Y] (in units of
// the distance) with one corner straight above it.
double corner_form_factor(double X, double Y) {
  const double a = std::sqrt(1 + X * X), b = std::sqrt(1 + Y * Y);
  return (X / a * std::atan(Y / a) + Y / b * std::atan(X / b)) / (2 * M_PI);
}

// A square rect light of radiance L, 1 above the centre of an albedo-1
// plane: the point below its centre gets E = 4 pi L F(0.5, 0.5), so it
// reflects 4 L F. Checks NEE + MIS (a double count or a missing term shows).
TEST(PathTracer, RectLightIrradianceMatchesFormFactor) {
  const float L = 3.f;
  Scene s = empty_scene();
  Material plane;
  plane.albedo = C3f(1, 1, 1);
  s.materials = {plane};
  add_quad(s, V3f(-4, 0, -4), V3f(4, 0, -4), V3f(4, 0, 4), V3f(-4, 0, 4), V3f(0, 1, 0), 0);
  Light light;
  light.prim_path = "/Light";
  light.kind = LightKind::Rect;
  // Local -Z (the emitting side) -> world -Y, at height 1.
  light.local_to_world = M44f(1, 0, 0, 0, 0, 0, -1, 0, 0, 1, 0, 0, 0, 1, 0, 1);
  light.radiance = C3f(L, L, L);
  light.width = light.height = 1.f;
  s.lights.push_back(light);
  const RayScene rays(s);
  // A very long lens sees only the neighbourhood of the centre.
  ReferenceOptions o = small_options(4, 512);
  const ReferenceImage img = render_reference(rays, down_camera(V3f(0, 0.5f, 0), 2000.f), o);
  const double expected = 4 * L * corner_form_factor(0.5, 0.5);
  double mean = 0;
  for (size_t i = 0; i < img.beauty.size(); ++i) {
    EXPECT_NEAR(img.direct[i], expected, 0.03 * expected);
    EXPECT_EQ(img.indirect[i], 0.f);  // a lone plane cannot see itself
    mean += img.direct[i];
  }
  EXPECT_NEAR(mean / double(img.direct.size()), expected, 0.01 * expected);
}

// A near-mirror floor (GGX roughness 0.05, metallic 1, white: F0 = 1)
// under a 1 x 1 rect light of radiance L at height 1. Straight down from
// below the light's centre the mirror direction is straight up, into the
// light, and the whole GGX lobe (alpha = 0.0025, a fraction of a degree)
// lies inside the light (26 degrees to its edge): the floor shows the
// light's radiance times the lobe's directional albedo, which is > 0.99 at
// normal incidence for F0 = 1 (brdf_test), so L within a few percent. Away
// from under the light the mirror direction misses it and the floor is
// dark, where a Lambert floor is lit. Checks that NEE and BSDF sampling of
// a narrow lobe are MIS-combined without double counting or losing either.
TEST(PathTracer, MirrorFloorReflectsRectLight) {
  const float L = 3.f;
  Scene s = empty_scene();
  Material mirror;
  mirror.albedo = C3f(1, 1, 1);
  mirror.roughness = 0.05f;
  mirror.metallic = 1.f;
  Material matte;
  matte.albedo = C3f(1, 1, 1);
  s.materials = {mirror, matte};
  add_quad(s, V3f(-4, 0, -4), V3f(4, 0, -4), V3f(4, 0, 4), V3f(-4, 0, 4), V3f(0, 1, 0), 0);
  Light light;
  light.prim_path = "/Light";
  light.kind = LightKind::Rect;
  light.local_to_world = M44f(1, 0, 0, 0, 0, 0, -1, 0, 0, 1, 0, 0, 0, 1, 0, 1);  // emits down
  light.radiance = C3f(L, L, L);
  light.width = light.height = 1.f;
  s.lights.push_back(light);
  const ReferenceOptions o = small_options(4, 256);
  auto mean_direct = [&](const Scene& scene, const V3f& eye) {
    const RayScene rays(scene);
    const ReferenceImage img = render_reference(rays, down_camera(eye, 2000.f), o);
    double sum = 0;
    for (size_t i = 0; i < img.direct.size(); ++i) {
      EXPECT_EQ(img.indirect[i], 0.f);  // a lone plane cannot see itself
      sum += img.direct[i];
    }
    return sum / double(img.direct.size());
  };
  const double centre = mean_direct(s, V3f(0, 0.5f, 0));
  EXPECT_NEAR(centre, L, 0.01 * L);
  const double aside = mean_direct(s, V3f(2.5f, 0.5f, 0));
  EXPECT_LT(aside, 1e-3 * L);
  std::printf("mirror floor: centre %.5f (L = %.1f), aside %.3g\n", centre, L, aside);
  // The same spot of a Lambert floor is lit (E / pi: 0.65% of L).
  Scene lambert = s;
  for (uint32_t& m : lambert.triangles.material) m = 1;
  EXPECT_GT(mean_direct(lambert, V3f(2.5f, 0.5f, 0)), 0.003 * L);
}

// The same floor under a distant light (a delta direction) 45 degrees high,
// seen by a very long lens placed on the mirror direction: the centre
// pixel looks exactly along the reflection of the light (5 x 5 pixels, so
// the optical axis is a pixel centre). There f = D G2 F / (4 cos_o cos_i)
// with the half vector on the normal: D = 1 / (pi alpha^2), F = F0 = 1 and
// G2 = 1 to 1e-5 at alpha = 0.0025, so the pixel shows
// E cos_i f = E / (4 pi alpha^2 cos 45). The pixel spans 4e-4 rad, which
// moves the half vector by at most 1e-4 rad and D by < 0.2%.
TEST(PathTracer, MirrorFloorReflectsDistantLightIntoTheCamera) {
  const float E = 1.f, roughness = 0.05f, alpha = roughness * roughness;
  Scene s = empty_scene();
  Material mirror;
  mirror.albedo = C3f(1, 1, 1);
  mirror.roughness = roughness;
  mirror.metallic = 1.f;
  s.materials = {mirror};
  add_quad(s, V3f(-4, 0, -4), V3f(4, 0, -4), V3f(4, 0, 4), V3f(-4, 0, 4), V3f(0, 1, 0), 0);
  const float c = std::sqrt(0.5f);
  Light sun;
  sun.prim_path = "/Sun";
  sun.kind = LightKind::Distant;
  // Local +Z toward the light, (-c, c, 0); it shines along local -Z.
  sun.local_to_world = M44f(0, 0, 1, 0, c, c, 0, 0, -c, c, 0, 0, 0, 0, 0, 1);
  sun.radiance = C3f(E, E, E);
  s.lights.push_back(sun);
  const RayScene rays(s);
  // Camera at 5 along the mirror direction (c, c, 0), looking at the origin.
  Camera cam;
  cam.prim_path = "/Camera";
  cam.local_to_world = M44f(0, 0, -1, 0, -c, c, 0, 0, c, c, 0, 0, 5 * c, 5 * c, 0, 1);
  cam.focal_length = 10000.f;
  ReferenceOptions o = small_options(5, 256);
  const ReferenceImage img = render_reference(rays, cam, o);
  const size_t centre = 3 * (2 * 5 + 2);
  const double expected = E / (4 * kPiF * alpha * alpha * c);
  std::printf("mirror floor under the sun: centre %.1f, expected %.1f\n", img.direct[centre], expected);
  EXPECT_NEAR(img.direct[centre], expected, 0.01 * expected);
  EXPECT_EQ(img.indirect[centre], 0.f);
}

// A small emissive quad (0.1 x 0.1, 1 above an albedo-1 plane) is the only
// light: the plane below its centre gets E = 4 pi L F(0.05, 0.05), and its
// indirect radiance is E / pi. BSDF sampling alone finds the quad once in
// ~300 paths (fireflies); next-event estimation of emissive triangles,
// MIS-combined, samples it at every vertex. Both are unbiased; the pixel
// spread at equal spp is what differs.
TEST(PathTracer, SmallEmissiveQuadIsSampledDirectly) {
  const float L = 100.f;
  Scene s = empty_scene();
  Material plane, emitter;
  plane.albedo = C3f(1, 1, 1);
  emitter.albedo = C3f(0, 0, 0);
  emitter.emission = C3f(L, L, L);
  s.materials = {plane, emitter};
  add_quad(s, V3f(-4, 0, -4), V3f(4, 0, -4), V3f(4, 0, 4), V3f(-4, 0, 4), V3f(0, 1, 0), 0);
  const float h = 0.05f;
  add_quad(s, V3f(-h, 1, -h), V3f(h, 1, -h), V3f(h, 1, h), V3f(-h, 1, h), V3f(0, -1, 0), 1);
  const RayScene rays(s);
  const double expected = 4 * L * corner_form_factor(h, h);  // indirect = E / pi

  struct Spread {
    double mean = 0, rel_std = 0;
  };
  auto measure = [&](bool nee) {
    ReferenceOptions o = small_options(16, 16);
    o.max_depth = 1;
    o.sample_emissive_triangles = nee;
    const ReferenceImage img = render_reference(rays, down_camera(V3f(0, 0.5f, 0), 2000.f), o);
    double sum = 0, sum2 = 0;
    const size_t n = img.indirect.size() / 3;
    for (size_t i = 0; i < n; ++i) {
      EXPECT_EQ(img.direct[3 * i], 0.f);  // no UsdLux light
      sum += img.indirect[3 * i];
      sum2 += double(img.indirect[3 * i]) * img.indirect[3 * i];
    }
    Spread out;
    out.mean = sum / double(n);
    out.rel_std = std::sqrt(std::max(0.0, sum2 / double(n) - out.mean * out.mean)) / expected;
    std::printf("small emitter, %s: mean / exact %.4f, pixel std / exact %.4f (16 spp)\n",
                nee ? "NEE + MIS" : "BSDF sampling only", out.mean / expected, out.rel_std);
    return out;
  };
  const Spread with = measure(true), without = measure(false);
  // With NEE each pixel is within a few percent (per-pixel std ~0.1%); the
  // mean of 256 pixels of BSDF-only sampling is within its own noise.
  EXPECT_NEAR(with.mean, expected, 0.01 * expected);
  EXPECT_LT(with.rel_std, 0.02);
  EXPECT_NEAR(without.mean, expected, 4 * without.rel_std / 16 * expected);
  // Variance at equal spp: far lower (measured ratio in the log).
  EXPECT_LT(with.rel_std * 50, without.rel_std);
}

// Camera rays see a rect light only from its emitting side, and only when
// lights_visible_to_camera is set.
TEST(PathTracer, LightsVisibleToCameraOption) {
  Scene s = empty_scene();
  s.materials = {Material{}};
  add_quad(s, V3f(-4, 0, -4), V3f(4, 0, -4), V3f(4, 0, 4), V3f(-4, 0, 4), V3f(0, 1, 0), 0);
  Light light;
  light.kind = LightKind::Rect;
  // Emits upward (+Y), toward a camera above it.
  light.local_to_world = M44f(1, 0, 0, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 0.5f, 0, 1);
  light.radiance = C3f(5, 5, 5);
  light.width = light.height = 4.f;
  s.lights.push_back(light);
  const RayScene rays(s);
  ReferenceOptions o = small_options(4, 2);
  const Camera cam = down_camera(V3f(0, 2, 0), 500.f);
  const ReferenceImage seen = render_reference(rays, cam, o);
  // A visible light hides the surface behind it (as in the daemon).
  for (float v : seen.beauty) EXPECT_NEAR(v, 5.f, 1e-4f);
  for (float v : seen.albedo) EXPECT_EQ(v, 0.f);
  for (float v : seen.ao) EXPECT_EQ(v, 1.f);
  o.lights_visible_to_camera = false;
  const ReferenceImage hidden = render_reference(rays, cam, o);
  for (float v : hidden.direct) EXPECT_EQ(v, 0.f);  // the light faces away from the floor
  for (float v : hidden.albedo) EXPECT_EQ(v, 0.5f);
}

Scene furnace_scene() {
  Scene s = empty_scene();
  Material m;
  m.albedo = C3f(0.7f, 0.5f, 0.3f);
  m.emission = C3f(0.2f, 0.1f, 0.3f);
  Material n;
  n.albedo = C3f(0.9f, 0.9f, 0.9f);
  s.materials = {m, n};
  add_inward_cube(s, 1.f, 0);
  add_quad(s, V3f(-0.5f, -0.3f, -0.8f), V3f(0.5f, -0.3f, -0.8f), V3f(0.5f, 0.4f, -0.6f),
           V3f(-0.5f, 0.4f, -0.6f), V3f(0, 0, 1), 1);
  return s;
}

bool same_image(const ReferenceImage& a, const ReferenceImage& b) {
  return a.beauty == b.beauty && a.direct == b.direct && a.indirect == b.indirect &&
         a.indirect1 == b.indirect1 && a.albedo == b.albedo && a.ao == b.ao;
}

TEST(PathTracer, DeterministicForAnyThreadCountAndPassSplit) {
  const Scene s = furnace_scene();
  const RayScene rays(s);
  ReferenceOptions o = small_options(20, 8);
  o.seed = 42;
  auto render_with = [&](int threads, const ReferenceOptions& opts) {
    tbb::task_arena arena(threads);
    ReferenceImage img;
    arena.execute([&] { img = render_reference(rays, origin_camera(), opts); });
    return img;
  };
  const ReferenceImage one = render_with(1, o);
  const ReferenceImage two = render_with(2, o);
  EXPECT_TRUE(same_image(one, two));
  ReferenceOptions split = o;
  split.pass_spp = 3;
  split.tile_size = 7;
  EXPECT_TRUE(same_image(one, render_with(2, split)));
  ReferenceOptions other_seed = o;
  other_seed.seed = 43;
  EXPECT_FALSE(same_image(one, render_with(2, other_seed)));
}

TEST(PathTracer, ProgressReportsPassesAndCanStop) {
  const Scene s = furnace_scene();
  const RayScene rays(s);
  ReferenceOptions o = small_options(8, 10);
  o.pass_spp = 4;
  std::vector<uint32_t> reported;
  const ReferenceImage all = render_reference(rays, origin_camera(), o, [&](const ReferenceProgress& p) {
    reported.push_back(p.spp_done);
    EXPECT_EQ(p.spp_total, 10u);
    return true;
  });
  EXPECT_EQ(reported, (std::vector<uint32_t>{4, 8, 10}));
  EXPECT_EQ(all.spp, 10u);
  const ReferenceImage stopped =
      render_reference(rays, origin_camera(), o, [](const ReferenceProgress& p) {
        return p.spp_done < 4;
      });
  EXPECT_EQ(stopped.spp, 4u);
  // The first pass is the same samples either way.
  ReferenceOptions four = o;
  four.spp = 4;
  EXPECT_TRUE(same_image(stopped, render_reference(rays, origin_camera(), four)));
}

TEST(PathTracer, RejectsBadOptions) {
  const Scene s = furnace_scene();
  const RayScene rays(s);
  ReferenceOptions o = small_options(8, 1);
  o.spp = 0;
  EXPECT_THROW(render_reference(rays, origin_camera(), o), InvalidArgument);
  o = small_options(0, 1);
  EXPECT_THROW(render_reference(rays, origin_camera(), o), InvalidArgument);
  o = small_options(8, 1);
  o.ao_max_distance = -1.f;
  EXPECT_THROW(render_reference(rays, origin_camera(), o), InvalidArgument);
}

}  // namespace
}  // namespace pbgi
