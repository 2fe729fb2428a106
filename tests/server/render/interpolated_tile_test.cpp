// The interpolating renderer (RenderOptions::interpolation = auto): it
// never takes a value across a depth or normal edge, stays near the
// per-sample gather, is independent of the tile split and thread count,
// and `off` gathers once per camera sample.
#include "common/errors.h"
#include "server/render/tile_renderer.h"
#include "server/surfels/surfels.h"
#include "storage/tree/memory_tree.h"
#include "storage/tree/tree_builder.h"
#include "tests/server/render/surfel_tree.h"
#include "tests/server/scene/test_scenes.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace pbgi {
namespace {

constexpr uint32_t kSize = 48;

// A camera at `eye` looking at `target`, +Z up (USD: looks down local -Z).
Camera look_at(const V3f& eye, const V3f& target) {
  const V3f back = (eye - target).normalized();
  const V3f right = V3f(0, 0, 1).cross(back).normalized();
  const V3f up = back.cross(right);
  Camera c;
  c.prim_path = "/cam";
  c.focal_length = 30.f;
  c.horizontal_aperture = 36.f;
  c.vertical_aperture = 36.f;
  c.local_to_world = M44f(right.x, right.y, right.z, 0, up.x, up.y, up.z, 0, back.x, back.y, back.z, 0, eye.x,
                          eye.y, eye.z, 1);
  return c;
}

// A floor, and a wall that glows standing on it (x = -1, facing +X): the
// floor near the wall gets bright indirect light, the wall only what the
// floor sends back. Seen obliquely, the corner is a normal edge between
// surfaces whose irradiance differs several times.
Scene corner_scene() {
  Scene s;
  s.source_path = "corner";
  const uint32_t floor = test::add_material(s, {0.5f, 0.5f, 0.5f});
  const uint32_t wall = test::add_material(s, {0.5f, 0.5f, 0.5f}, {2.f, 2.f, 2.f});
  test::add_square_z(s, 0, 0, 0, 2.f, floor, false, "/floor");
  test::add_quad(s, V3f(-1, -2, 0), V3f(-1, 2, 0), V3f(-1, 2, 2), V3f(-1, -2, 2), wall, "/wall");
  s.cameras["/cam"] = look_at(V3f(1.5f, 0.3f, 1.4f), V3f(-1.f, 0.f, 0.3f));
  return s;
}

// A thin slab (z = 0.3) over a floor, its underside glowing, seen from
// above: the slab's top sees nothing (indirect 0); the floor around it gets
// the underside's light. The slab's outline is a depth edge.
Scene slab_scene() {
  Scene s;
  s.source_path = "slab";
  const uint32_t floor = test::add_material(s, {0.5f, 0.5f, 0.5f});
  const uint32_t top = test::add_material(s, {0.8f, 0.8f, 0.8f});
  const uint32_t glow = test::add_material(s, {0.8f, 0.8f, 0.8f}, {4.f, 4.f, 4.f});
  test::add_square_z(s, 0, 0, 0, 2.f, floor, false, "/floor");
  test::add_square_z(s, 0.1f, 0.05f, 0.3f, 0.4f, top, false, "/slab_top");
  test::add_square_z(s, 0.1f, 0.05f, 0.3f, 0.4f, glow, true, "/slab_bottom");
  s.cameras["/cam"] = look_at(V3f(0.2f, -0.4f, 2.2f), V3f(0.f, 0.f, 0.f));
  return s;
}

// A rect light under a ceiling, seen from below over a floor: its outline
// against the ceiling is the image's largest contrast (radiance 20 against
// the ceiling's ~0.1).
Scene light_scene() {
  Scene s;
  s.source_path = "light";
  const uint32_t grey = test::add_material(s, {0.5f, 0.5f, 0.5f});
  test::add_square_z(s, 0, 0, 0, 2.f, grey, false, "/floor");
  test::add_square_z(s, 0, 0, 1.2f, 2.f, grey, true, "/ceiling");
  s.lights.push_back(test::rect_light(0.f, 0.f, 1.1f, 0.6f, 0.4f, {20.f, 20.f, 20.f}));
  s.cameras["/cam"] = look_at(V3f(1.6f, 0.4f, 0.3f), V3f(0.f, 0.f, 1.1f));
  return s;
}

tree::MemoryTree surfel_tree(const Scene& s) { return test::direct_light_tree(s, 20000); }

RenderOptions options(InterpolationMode mode, uint32_t pixel_samples = 1) {
  RenderOptions o;
  o.interpolation.mode = mode;
  o.pixel_samples = pixel_samples;
  o.light_samples = 1;
  return o;
}

float luminance(const std::vector<float>& rgb, size_t i) {
  return 0.2126f * rgb[3 * i] + 0.7152f * rgb[3 * i + 1] + 0.0722f * rgb[3 * i + 2];
}

struct Rendered {
  TileAovs aovs;
  GatherCounters counters;
};

Rendered render(const Scene& s, const tree::TreeSource& tree, const RenderOptions& o,
                TileRect rect = {0, 0, kSize, kSize}) {
  const RayScene rays(s);
  Rendered r;
  r.aovs = render_tile(rays, tree, *s.find_camera("/cam"), kSize, kSize, rect, o, &r.counters);
  return r;
}

// Relative indirect error of `a` against the per-sample render `b`,
// pixel by pixel, for pixels where b is at least `floor` (its mean too).
struct Deviation {
  float max = 0.f, mean = 0.f;
};
Deviation deviation(const TileAovs& a, const TileAovs& b, float floor) {
  Deviation d;
  size_t n = 0;
  for (size_t i = 0; i < b.ao.size(); ++i) {
    const float ref = luminance(b.indirect, i);
    if (ref < floor) continue;
    const float e = std::fabs(luminance(a.indirect, i) - ref) / ref;
    d.max = std::max(d.max, e);
    d.mean += e;
    ++n;
  }
  d.mean = n ? d.mean / float(n) : 0.f;
  return d;
}

// Every tile of each size renders its pixels (beauty, indirect, AO) as
// the whole image does, bit for bit.
void expect_tiles_match(const Scene& s, const tree::TreeSource& tree, const RenderOptions& o, const Rendered& whole,
                        std::initializer_list<uint32_t> tiles) {
  for (const uint32_t tile : tiles) {
    for (uint32_t y0 = 0; y0 < kSize; y0 += tile)
      for (uint32_t x0 = 0; x0 < kSize; x0 += tile) {
        const TileRect r{x0, y0, std::min(x0 + tile, kSize), std::min(y0 + tile, kSize)};
        const Rendered part = render(s, tree, o, r);
        for (uint32_t y = r.y0; y < r.y1; ++y)
          for (uint32_t x = r.x0; x < r.x1; ++x) {
            const size_t i = (y - r.y0) * r.width() + (x - r.x0), j = y * kSize + x;
            ASSERT_EQ(part.aovs.ao[i], whole.aovs.ao[j]) << tile << ": " << x << "," << y;
            for (int c = 0; c < 3; ++c) {
              ASSERT_EQ(part.aovs.indirect[3 * i + c], whole.aovs.indirect[3 * j + c]) << tile << ": " << x << "," << y;
              ASSERT_EQ(part.aovs.beauty[3 * i + c], whole.aovs.beauty[3 * j + c]) << tile << ": " << x << "," << y;
            }
          }
      }
  }
}

TEST(InterpolatedTile, NeverTakesAValueAcrossANormalEdge) {
  const Scene s = corner_scene();
  const tree::MemoryTree tree = surfel_tree(s);
  const Rendered off = render(s, tree, options(InterpolationMode::kOff));
  const Rendered on = render(s, tree, options(InterpolationMode::kAuto));
  // The corner is a real edge: the brightest floor pixels are several
  // times the brightest wall pixels.
  const RayScene rays(s);
  float floor_max = 0.f, wall_max = 0.f;
  for (uint32_t y = 0; y < kSize; ++y)
    for (uint32_t x = 0; x < kSize; ++x) {
      const Ray ray = camera_ray(*s.find_camera("/cam"), kSize, kSize, x + 0.5f, y + 0.5f);
      const Hit h = rays.intersect(ray.origin, ray.direction, ray.tmin, ray.tmax);
      if (!h.valid()) continue;
      const float e = luminance(off.aovs.indirect, y * kSize + x);
      (s.triangles.mesh[h.triangle] == 0 ? floor_max : wall_max) = std::max(
          s.triangles.mesh[h.triangle] == 0 ? floor_max : wall_max, e);
    }
  ASSERT_GT(floor_max, 3.f * wall_max);
  // A pixel next to the corner that took the other side's value would be
  // off by a factor of several; interpolation along a surface is not.
  const Deviation d = deviation(on.aovs, off.aovs, 1e-4f);
  EXPECT_LT(d.max, 0.3f);
  EXPECT_LT(d.mean, 0.03f);
  EXPECT_LT(on.counters.receivers, off.counters.receivers);
}

TEST(InterpolatedTile, NeverTakesAValueAcrossADepthEdge) {
  const Scene s = slab_scene();
  const tree::MemoryTree tree = surfel_tree(s);
  const Rendered off = render(s, tree, options(InterpolationMode::kOff));
  const Rendered on = render(s, tree, options(InterpolationMode::kAuto));
  size_t dark = 0, lit = 0;
  float lit_max = 0.f;
  for (size_t i = 0; i < off.aovs.ao.size(); ++i) lit_max = std::max(lit_max, luminance(off.aovs.indirect, i));
  // The slab's top gathers nothing: zero up to the rounding noise of senders
  // at grazing angles (1e-20 with the rounded payloads of the trees this
  // build makes, storage/tree/payload_rounding.h; up to 1e-7 of the
  // floor's brightest since decoded positions lie on a leaf's coarse grid,
  // storage/tree/page_records.h, a step above or below the top's plane). A
  // value taken across the edge would be of the floor's order.
  const float zero = 1e-6f * lit_max;
  for (size_t i = 0; i < off.aovs.ao.size(); ++i) {
    if (luminance(off.aovs.indirect, i) <= zero) {
      ++dark;
      EXPECT_LE(luminance(on.aovs.indirect, i), zero) << "pixel " << i;
    } else {
      ++lit;
    }
  }
  ASSERT_GT(dark, 100u);
  ASSERT_GT(lit, 100u);
  const Deviation d = deviation(on.aovs, off.aovs, 1e-4f);
  EXPECT_LT(d.max, 0.3f);
  EXPECT_LT(d.mean, 0.03f);
}

// Antialiased: four camera samples per pixel share the lattice's gathers.
TEST(InterpolatedTile, CameraSamplesShareGathers) {
  const Scene s = corner_scene();
  const tree::MemoryTree tree = surfel_tree(s);
  const Rendered on = render(s, tree, options(InterpolationMode::kAuto, 4));
  EXPECT_EQ(on.aovs.camera_samples, 4u * kSize * kSize);
  EXPECT_LT(on.counters.receivers, uint64_t{kSize} * kSize);  // fewer gathers than pixels
  const Rendered off = render(s, tree, options(InterpolationMode::kOff, 4));
  EXPECT_EQ(off.counters.receivers, 4u * kSize * kSize);  // every sample hits the corner's surfaces
}

TEST(InterpolatedTile, TheSameWhateverTheTileSplitAndThreads) {
  const Scene s = slab_scene();
  const tree::MemoryTree tree = surfel_tree(s);
  const RenderOptions o = options(InterpolationMode::kAuto, 2);
  const Rendered whole = render(s, tree, o);
  // Tiles aligned with the lattice and not (odd sizes, odd origins).
  expect_tiles_match(s, tree, o, whole, {16u, 13u, 7u});
  tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
  const Rendered serial = render(s, tree, o);
  EXPECT_EQ(serial.aovs.beauty, whole.aovs.beauty);
  EXPECT_EQ(serial.aovs.indirect, whole.aovs.indirect);
  EXPECT_EQ(serial.aovs.ao, whole.aovs.ao);
}

// Off: each pixel (one sample, through its centre) is the gather at its
// own receiver, as before interpolation existed.
TEST(InterpolatedTile, OffGathersAtEveryPixel) {
  const Scene s = corner_scene();
  const tree::MemoryTree tree = surfel_tree(s);
  const RenderOptions o = options(InterpolationMode::kOff);
  const Rendered off = render(s, tree, o);
  const RayScene rays(s);
  Gatherer gatherer(tree, o.gather);
  for (uint32_t y = 0; y < kSize; y += 5)
    for (uint32_t x = 0; x < kSize; x += 3) {
      const Ray ray = camera_ray(*s.find_camera("/cam"), kSize, kSize, x + 0.5f, y + 0.5f);
      const SurfaceSample sample = trace_sample(rays, ray, 0, 0);
      if (!sample.gathers) continue;
      const GatherResult g = gatherer.gather(sample.receiver);
      const size_t i = y * kSize + x;
      EXPECT_EQ(off.aovs.ao[i], g.ao);
      const C3f indirect = sample.indirect_brdf * g.irradiance;
      EXPECT_EQ(off.aovs.indirect[3 * i], indirect.x);
    }
}

TEST(InterpolatedTile, BadOptionsAreRefusedNamingTheField) {
  const Scene s = slab_scene();
  const tree::MemoryTree tree = surfel_tree(s);
  const auto refused = [&](const RenderOptions& o, const std::string& field) {
    try {
      render(s, tree, o);
      ADD_FAILURE() << "accepted: " << field;
    } catch (const InvalidArgument& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  };
  for (const float t : {-0.1f, 0.f, 1.5f, std::numeric_limits<float>::quiet_NaN(),
                        std::numeric_limits<float>::infinity()}) {
    RenderOptions o;
    o.interpolation.tolerance = t;
    refused(o, "interpolation_tolerance");
  }
  for (const uint32_t spacing : {0u, 3u, 128u}) {
    RenderOptions o;
    o.interpolation.spacing = spacing;
    refused(o, "interpolation_spacing");
  }
  RenderOptions o;
  o.pixel_samples = 0;
  refused(o, "pixel_samples");
  o = RenderOptions{};
  o.edge_samples = 5000;
  refused(o, "edge_samples");
}

float beauty_mse(const TileAovs& a, const TileAovs& b) {
  double sum = 0;
  for (size_t i = 0; i < a.beauty.size(); ++i) sum += double(a.beauty[i] - b.beauty[i]) * (a.beauty[i] - b.beauty[i]);
  return float(sum / double(a.beauty.size()));
}

// A light seen directly: the pixels on its silhouette get edge_samples
// camera rays of their own, which removes most of the beauty's aliasing
// at few extra gathers.
TEST(InterpolatedTile, LightSilhouettesGetTheirOwnSamples) {
  const Scene s = light_scene();
  const tree::MemoryTree tree = surfel_tree(s);
  RenderOptions o = options(InterpolationMode::kAuto, 4);
  o.light_samples = 16;
  o.edge_samples = 0;
  const Rendered plain = render(s, tree, o);
  o.edge_samples = 256;
  const Rendered edges = render(s, tree, o);
  RenderOptions fine = o;
  fine.pixel_samples = 256;
  fine.edge_samples = 0;
  fine.light_samples = 256;
  const Rendered reference = render(s, tree, fine);

  const uint64_t pixels = uint64_t{kSize} * kSize;
  EXPECT_EQ(plain.aovs.camera_samples, 4 * pixels);
  // Some pixels, not all, traced 256 more camera rays.
  ASSERT_GT(edges.aovs.camera_samples, 4 * pixels);
  EXPECT_EQ((edges.aovs.camera_samples - 4 * pixels) % 256, 0u);
  EXPECT_LT(edges.aovs.camera_samples - 4 * pixels, 256 * pixels / 4);
  // Silhouette samples mostly take the lattice's or their pixel's gathers.
  EXPECT_LT(edges.counters.receivers, plain.counters.receivers + pixels / 20);
  const float before = beauty_mse(plain.aovs, reference.aovs), after = beauty_mse(edges.aovs, reference.aovs);
  EXPECT_LT(after, before / 4) << "beauty MSE " << before << " -> " << after;
  // The pixels away from the light are rendered as without edge samples.
  size_t same = 0;
  for (size_t i = 0; i < plain.aovs.ao.size(); ++i) same += plain.aovs.beauty[3 * i] == edges.aovs.beauty[3 * i];
  EXPECT_GT(same, plain.aovs.ao.size() / 2);
}

TEST(InterpolatedTile, LightSilhouettesTheSameWhateverTheTileSplit) {
  const Scene s = light_scene();
  const tree::MemoryTree tree = surfel_tree(s);
  RenderOptions o = options(InterpolationMode::kAuto, 2);
  o.edge_samples = 16;
  const Rendered whole = render(s, tree, o);
  expect_tiles_match(s, tree, o, whole, {16u, 7u});
}

TEST(InterpolationMode, NamesRoundTrip) {
  for (const InterpolationMode m : {InterpolationMode::kOff, InterpolationMode::kAuto})
    EXPECT_EQ(parse_interpolation_mode(interpolation_mode_name(m)), m);
  EXPECT_FALSE(parse_interpolation_mode("sometimes").has_value());
}

}  // namespace
}  // namespace pbgi
