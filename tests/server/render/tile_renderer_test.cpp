#include "server/render/tile_renderer.h"
#include "common/errors.h"
#include "server/scene/brdf.h"
#include "server/surfels/surfels.h"
#include "storage/tree/memory_tree.h"
#include "storage/tree/tree_builder.h"
#include "tests/server/render/surfel_tree.h"
#include "tests/server/scene/test_scenes.h"

#include <gtest/gtest.h>

#include <cmath>

namespace pbgi {
namespace {

constexpr uint32_t kSize = 15;  // odd: the center pixel's center is on the axis
constexpr float kAlbedo = 0.5f;

// A tree with nothing in it: one leaf of area 0.
class EmptyTree final : public tree::TreeSource {
 public:
  EmptyTree() {
    auto page = std::make_shared<tree::Page>();
    page->nodes.resize(1);
    page_ = page;
  }
  tree::NodeRef root() const override { return {0, 0}; }
  tree::PagePtr page(uint32_t) const override { return page_; }

 private:
  tree::PagePtr page_;
};

// Floor [-2,2]^2 at z = 0; a 1x1 rect light at (1.5, 0, 1) facing down;
// camera at (0, 0, 3) looking down -Z (the light's back is invisible).
Scene floor_scene() {
  Scene s;
  s.source_path = "floor";
  const uint32_t m = test::add_material(s, {kAlbedo, kAlbedo, kAlbedo});
  test::add_square_z(s, 0, 0, 0, 2.f, m, false, "/floor");
  s.lights.push_back(test::rect_light(1.5f, 0, 1.f, 1.f, 1.f, {4.f, 4.f, 4.f}));
  Camera cam;
  cam.prim_path = "/cam";
  cam.focal_length = 35.f;
  cam.horizontal_aperture = 36.f;
  cam.local_to_world.makeIdentity();
  cam.local_to_world.setTranslation(V3f(0, 0, 3));
  s.cameras["/cam"] = cam;
  return s;
}

TileRect whole() { return {0, 0, kSize, kSize}; }

TEST(RenderTile, RejectsTilesOutsideTheImage) {
  const Scene s = floor_scene();
  const RayScene rays(s);
  const EmptyTree tree;
  const Camera& cam = *s.find_camera("/cam");
  try {
    render_tile(rays, tree, cam, 64, 48, {32, 32, 64, 64}, RenderOptions());
    FAIL() << "expected InvalidArgument";
  } catch (const InvalidArgument& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("64x48"), std::string::npos) << msg;
    EXPECT_NE(msg.find("[32, 64)"), std::string::npos) << msg;
  }
  EXPECT_THROW(render_tile(rays, tree, cam, 64, 48, {8, 8, 8, 16}, RenderOptions()),
               InvalidArgument);  // empty
  RenderOptions bad;
  bad.pixel_samples = 0;
  EXPECT_THROW(render_tile(rays, tree, cam, 64, 48, {0, 0, 8, 8}, bad), InvalidArgument);
}

TEST(RenderTile, EmptyTreeGivesZeroIndirect) {
  const Scene s = floor_scene();
  const RayScene rays(s);
  const EmptyTree tree;
  GatherCounters counters;
  RenderOptions per_sample;  // one gather per camera sample, counted below
  per_sample.interpolation.mode = InterpolationMode::kOff;
  per_sample.pixel_samples = 1;
  const TileAovs out =
      render_tile(rays, tree, *s.find_camera("/cam"), kSize, kSize, whole(), per_sample, &counters);
  ASSERT_EQ(out.beauty.size(), 3u * kSize * kSize);
  ASSERT_EQ(out.ao.size(), 1u * kSize * kSize);
  for (size_t i = 0; i < out.ao.size(); ++i) {
    EXPECT_EQ(out.ao[i], 1.f);
    for (int c = 0; c < 3; ++c) {
      EXPECT_EQ(out.indirect[3 * i + c], 0.f);
      EXPECT_EQ(out.beauty[3 * i + c], out.direct[3 * i + c]);
      EXPECT_EQ(out.albedo[3 * i + c], kAlbedo);  // every pixel sees the floor
    }
    EXPECT_GT(out.direct[3 * i], 0.f);
  }
  EXPECT_EQ(counters.receivers, uint64_t{kSize} * kSize);
}

// The center pixel of `s` rendered with 1024 light samples and no tree.
TileAovs center_pixel_direct(const Scene& s) {
  const RayScene rays(s);
  const EmptyTree tree;
  RenderOptions o;
  o.light_samples = 1024;
  o.pixel_samples = 1;  // the pixel's centre: the analytic point
  const uint32_t c = kSize / 2;
  return render_tile(rays, tree, *s.find_camera("/cam"), kSize, kSize, {c, c, c + 1, c + 1}, o);
}

TEST(RenderTile, DirectMatchesAnalytic) {
  const TileAovs out = center_pixel_direct(floor_scene());
  const double e = test::rect_irradiance(4.0, 1.0, 2.0, -0.5, 0.5, 0.0, 0.0, 1.0);
  EXPECT_NEAR(out.direct[0] / (kAlbedo / M_PI * e), 1.0, 0.01);
}

TEST(RenderTile, LightSeenByTheCameraShowsItsRadiance) {
  Scene s = floor_scene();
  Camera& cam = s.cameras["/cam"];
  // Below the light, looking up (+Z): rows are the images of local X, Y, Z.
  cam.local_to_world = M44f(1, 0, 0, 0, 0, -1, 0, 0, 0, 0, -1, 0, 1.5f, 0, 0.5f, 1);
  const RayScene rays(s);
  const EmptyTree tree;
  const uint32_t c = kSize / 2;
  const TileAovs out = render_tile(rays, tree, cam, kSize, kSize, {c, c, c + 1, c + 1}, RenderOptions());
  EXPECT_EQ(out.beauty[0], 4.f);
  EXPECT_EQ(out.direct[0], 4.f);
  EXPECT_EQ(out.albedo[0], 0.f);
  EXPECT_EQ(out.ao[0], 1.f);
}

TEST(RenderTile, MissIsBlackAndUnoccluded) {
  Scene s = floor_scene();
  s.cameras["/cam"].local_to_world.makeIdentity();
  s.cameras["/cam"].local_to_world.setTranslation(V3f(0, 0, -1));  // under the floor, facing away
  const RayScene rays(s);
  const EmptyTree tree;
  const TileAovs out =
      render_tile(rays, tree, s.cameras["/cam"], kSize, kSize, {0, 0, 4, 4}, RenderOptions());
  for (float v : out.beauty) EXPECT_EQ(v, 0.f);
  for (float v : out.ao) EXPECT_EQ(v, 1.f);
}

// Escaping camera rays see the dome (the sky behind an outdoor scene),
// in beauty and direct, unless the render options hide it.
TEST(RenderTile, MissSeesTheDomeUnlessHidden) {
  Scene s = floor_scene();
  s.cameras["/cam"].local_to_world.makeIdentity();
  s.cameras["/cam"].local_to_world.setTranslation(V3f(0, 0, -1));  // under the floor, facing away
  Light dome;
  dome.kind = LightKind::Dome;
  dome.prim_path = "/sky";
  dome.radiance = C3f(0.2f, 0.3f, 0.4f);
  s.lights.push_back(dome);
  const RayScene rays(s);
  const EmptyTree tree;
  RenderOptions options;
  const TileAovs seen = render_tile(rays, tree, s.cameras["/cam"], kSize, kSize, {0, 0, 4, 4}, options);
  for (size_t i = 0; i < seen.ao.size(); ++i) {
    for (int c = 0; c < 3; ++c) {
      EXPECT_FLOAT_EQ(seen.beauty[3 * i + c], dome.radiance[c]) << i;
      EXPECT_FLOAT_EQ(seen.direct[3 * i + c], dome.radiance[c]) << i;
      EXPECT_EQ(seen.albedo[3 * i + c], 0.f);
    }
    EXPECT_EQ(seen.ao[i], 1.f);
  }
  options.dome_visible = false;
  const TileAovs hidden = render_tile(rays, tree, s.cameras["/cam"], kSize, kSize, {0, 0, 4, 4}, options);
  for (float v : hidden.beauty) EXPECT_EQ(v, 0.f);
}

TEST(RenderTile, CameraSeesOnlyWithinItsClippingRange) {
  // An occluder (albedo 0.2) at z = 2 over the floor (albedo 0.5) at z = 0;
  // the camera at z = 3 looks down the axis, so the center pixel's ray hits
  // them at depths 1 and 3.
  Scene s = floor_scene();
  const float occluder_albedo = 0.2f;
  const uint32_t m = test::add_material(s, {occluder_albedo, occluder_albedo, occluder_albedo});
  test::add_square_z(s, 0, 0, 2.f, 0.5f, m, false, "/occluder");
  const RayScene rays(s);
  const EmptyTree tree;
  const uint32_t c = kSize / 2;
  auto center_albedo = [&](float near_clip, float far_clip) {
    Camera cam = s.cameras.at("/cam");
    cam.near_clip = near_clip;
    cam.far_clip = far_clip;
    return render_tile(rays, tree, cam, kSize, kSize, {c, c, c + 1, c + 1}, RenderOptions()).albedo[0];
  };
  EXPECT_EQ(center_albedo(0.01f, 100.f), occluder_albedo);
  EXPECT_EQ(center_albedo(1.5f, 100.f), kAlbedo);  // the near plane cuts the occluder away
  EXPECT_EQ(center_albedo(1.5f, 2.5f), 0.f);       // and the far plane the floor
}

TEST(RenderTile, TilesMatchTheWholeImage) {
  const Scene s = floor_scene();
  const RayScene rays(s);
  const EmptyTree tree;
  RenderOptions o;
  o.pixel_samples = 4;
  const Camera& cam = *s.find_camera("/cam");
  const TileAovs full = render_tile(rays, tree, cam, kSize, kSize, whole(), o);
  const TileAovs part = render_tile(rays, tree, cam, kSize, kSize, {5, 3, 12, 9}, o);
  for (uint32_t y = 3; y < 9; ++y) {
    for (uint32_t x = 5; x < 12; ++x) {
      const size_t i = (y - 3) * 7 + (x - 5), j = y * kSize + x;
      for (int c = 0; c < 3; ++c) ASSERT_EQ(part.beauty[3 * i + c], full.beauty[3 * j + c]);
    }
  }
}

TEST(RenderTile, CancelledThrows) {
  const Scene s = floor_scene();
  const RayScene rays(s);
  const EmptyTree tree;
  int calls = 0;
  EXPECT_THROW(render_tile(rays, tree, *s.find_camera("/cam"), kSize, kSize, whole(),
                           RenderOptions(), nullptr, [&] { return ++calls > 3; }),
               Cancelled);
}

// floor_scene() with a red wall at x = -1 facing +X, lit by a light facing
// it, and the surfel tree of its direct light.
Scene red_wall_scene() {
  Scene s = floor_scene();
  const uint32_t red = test::add_material(s, {0.9f, 0.1f, 0.1f});
  test::add_quad(s, V3f(-1, -2, 0), V3f(-1, 2, 0), V3f(-1, 2, 2), V3f(-1, -2, 2), red, "/wall");
  Light l = test::rect_light(0, 0, 0, 1.f, 1.f, {20, 20, 20});
  // local -Z -> world -X: rows X->(0,1,0)... use Y->Z, Z->X.
  l.local_to_world = M44f(0, 1, 0, 0, 0, 0, 1, 0, 1, 0, 0, 0, 0.5f, 0, 1.5f, 1);
  s.lights = {l};
  return s;
}

tree::MemoryTree direct_light_tree(const Scene& s) { return test::direct_light_tree(s, 4000); }

// The pixel at x ~ -0.6 on the floor, looking down.
constexpr uint32_t kRedSideRow = kSize / 2;
constexpr TileRect kRedSidePixel{4, kRedSideRow, 5, kRedSideRow + 1};

TEST(RenderTile, IndirectLightFromSurfels) {
  // The floor next to a red-lit wall: the floor receives red indirect light.
  const Scene s = red_wall_scene();
  const RayScene rays(s);
  const tree::MemoryTree tree = direct_light_tree(s);
  const TileAovs out = render_tile(rays, tree, *s.find_camera("/cam"), kSize, kSize,
                                   kRedSidePixel, RenderOptions());
  EXPECT_GT(out.indirect[0], 0.f);
  EXPECT_GT(out.indirect[0], 3.f * out.indirect[1]);  // red dominates
  EXPECT_LT(out.ao[0], 1.f);
}

// A metal floor (no diffuse lobe) next to the red-lit wall: all its
// indirect light is the glossy gather towards the camera, folded into the
// indirect AOV as the reference defines it (full BRDF at the hit).
TEST(RenderTile, GlossyMaterialsReflectIndirectLightTowardsTheCamera) {
  Scene s = red_wall_scene();
  const tree::MemoryTree tree = direct_light_tree(s);
  const RayScene matte_rays(s);
  // Per-sample gathers: the matte pixel's AO is its own gather's, as the
  // metal's is (a glossy sample always gathers itself).
  RenderOptions per_sample;
  per_sample.interpolation.mode = InterpolationMode::kOff;
  per_sample.pixel_samples = 1;  // one glossy receiver, counted below
  const TileAovs matte = render_tile(matte_rays, tree, *s.find_camera("/cam"), kSize, kSize,
                                     kRedSidePixel, per_sample);
  // The floor turned into a rough metal: diffuse lobe 0, F0 = albedo.
  Material& floor = s.materials[0];  // floor_scene's first material
  ASSERT_EQ(floor.albedo.x, kAlbedo);
  floor.metallic = 1.f;
  floor.roughness = 0.5f;
  const RayScene metal_rays(s);
  GatherCounters counters;
  const TileAovs metal = render_tile(metal_rays, tree, *s.find_camera("/cam"), kSize, kSize,
                                     kRedSidePixel, per_sample, &counters);
  EXPECT_EQ(counters.glossy_receivers, 1u);
  EXPECT_GT(metal.indirect[0], 0.01f * matte.indirect[0]);
  EXPECT_GT(metal.indirect[0], 3.f * metal.indirect[1]);  // it reflects the red wall
  EXPECT_EQ(metal.ao[0], matte.ao[0]);                    // the diffuse gather is unchanged
}

// A metal floor under the rect light: its direct light goes through the
// GGX lobe (no Lambertian term), as the reference's direct AOV: equal to
// the integral of f(wo, wi) L cos_i cos_l / d^2 over the light, taken here
// by brute force on a fine grid of the light.
TEST(RenderTile, GlossyDirectLightGoesThroughTheLobe) {
  Scene s = floor_scene();
  Material& floor = s.materials[0];
  floor.metallic = 1.f;
  floor.roughness = 0.4f;
  const TileAovs out = center_pixel_direct(s);
  // The center pixel sees the floor's origin from (0, 0, 3).
  const BrdfLobes lobes = brdf_lobes(floor, floor.albedo);
  ASSERT_TRUE(lobes.specular);
  const Brdf brdf(lobes, V3f(0, 0, 1));
  const V3f p(0, 0, 0), wo(0, 0, 1);
  constexpr int kGrid = 400;
  double want = 0.0;
  for (int i = 0; i < kGrid; ++i) {
    for (int j = 0; j < kGrid; ++j) {
      const V3f q(1.f + (i + 0.5f) / kGrid, -0.5f + (j + 0.5f) / kGrid, 1.f);  // the light, facing down
      const V3f d = q - p;
      const float r2 = d.length2();
      const V3f wi = d / std::sqrt(r2);
      const double cos_l = wi.z;  // the light's normal is -z
      want += brdf.eval(wo, wi).x * 4.0 * wi.z * cos_l / r2 / (double(kGrid) * kGrid);
    }
  }
  ASSERT_GT(want, 0.0);
  EXPECT_NEAR(out.direct[0] / want, 1.0, 0.03) << out.direct[0] << " vs " << want;
  // The Lambertian shading it replaced would be albedo / pi x E.
  const double lambert = kAlbedo / M_PI * test::rect_irradiance(4.0, 1.0, 2.0, -0.5, 0.5, 0.0, 0.0, 1.0);
  EXPECT_GT(std::abs(out.direct[0] / lambert - 1.0), 0.1);
}

}  // namespace
}  // namespace pbgi
