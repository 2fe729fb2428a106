// Fog grids in light transport: the ray-marched field (optical depth of a
// slab), shadow rays of direct lighting attenuated by exp(-tau), the volume
// points' level of detail and single scattering, and the gather seeing them
// as an attenuating layer (irradiance through a slab, AO behind a cube).
#include "server/gather/gather.h"
#include "server/scene/direct_lighting.h"
#include "server/scene/ray_scene.h"
#include "server/scene/volume_points.h"
#include "server/volumes/fog_field.h"
#include "server/volumes/fog_points.h"
#include "server/volumes/volume_grid.h"
#include "tests/server/gather/surfel_shapes.h"
#include "tests/server/gather/surfel_tree.h"

#include <openvdb/openvdb.h>

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <memory>

namespace pbgi {
namespace {

constexpr float kVoxel = 0.1f;

// A fog volume whose grid has `density` on the voxels of index box
// [lo, hi] (inclusive), voxel size kVoxel, identity transform.
Volume fog_box(const openvdb::Coord& lo, const openvdb::Coord& hi, float density) {
  openvdb::initialize();
  openvdb::FloatGrid::Ptr grid = openvdb::FloatGrid::create(0.f);
  grid->setTransform(openvdb::math::Transform::createLinearTransform(kVoxel));
  grid->setGridClass(openvdb::GRID_FOG_VOLUME);
  if (density != 0.f) grid->denseFill(openvdb::CoordBBox(lo, hi), density, /*active=*/true);
  Volume v;
  v.prim_path = "/Fog";
  v.kind = VolumeKind::Fog;
  v.voxel_size = kVoxel;
  v.grid = std::make_shared<VolumeGrid>(grid);
  const openvdb::CoordBBox active = grid->evalActiveVoxelBoundingBox();
  if (!active.empty()) {
    v.bounds.extendBy(V3f((active.min().x() - 0.5f) * kVoxel, (active.min().y() - 0.5f) * kVoxel,
                          (active.min().z() - 0.5f) * kVoxel));
    v.bounds.extendBy(V3f((active.max().x() + 0.5f) * kVoxel, (active.max().y() + 0.5f) * kVoxel,
                          (active.max().z() + 0.5f) * kVoxel));
  }
  return v;
}

// A slab z in [1, 2) (voxel centres 10..19 cover [0.95, 1.95]), |x|, |y| < 2.
Volume slab(float density) { return fog_box({-20, -20, 10}, {20, 20, 19}, density); }

// A floor at z = 0 (two big triangles facing +z) and a sun straight above.
Scene lit_floor() {
  Scene s;
  s.source_path = "fog_test";
  s.materials.resize(1);
  s.triangles.positions = {{-50, -50, 0}, {50, -50, 0}, {50, 50, 0}, {-50, 50, 0}};
  s.triangles.indices = {0, 1, 2, 0, 2, 3};
  s.triangles.material = {0, 0};
  Light sun;
  sun.kind = LightKind::Distant;  // shines along its local -Z: from +z down
  sun.radiance = C3f(2.f);
  sun.angle_degrees = 0.5f;
  s.lights.push_back(sun);
  return s;
}

TEST(FogField, OpticalDepthOfASlabIsDensityTimesThickness) {
  Scene s;
  s.volumes.push_back(slab(0.7f));
  FogOptions o;
  o.extinction_per_density = 2.f;
  const FogField field(s, o);
  ASSERT_FALSE(field.empty());
  // Straight through: 2 * 0.7 * 1.0.
  EXPECT_NEAR(field.optical_depth(V3f(0.1f, 0.2f, 0.f), V3f(0, 0, 1), 0.f, 10.f), 1.4f, 0.03f);
  // Stopping halfway through the slab.
  EXPECT_NEAR(field.optical_depth(V3f(0.f, 0.f, 0.f), V3f(0, 0, 1), 0.f, 1.45f), 0.7f, 0.05f);
  // Obliquely: the path is 1 / cos longer.
  const V3f d = V3f(0.6f, 0.f, 0.8f);
  EXPECT_NEAR(field.optical_depth(V3f(0.f, 0.f, 0.f), d, 0.f, 10.f), 1.4f / 0.8f, 0.04f);
  // Missing the slab.
  EXPECT_EQ(field.transmittance(V3f(0, 0, 3), V3f(0, 0, 1), 0.f, 10.f), 1.f);
  EXPECT_NEAR(field.extinction(V3f(0, 0, 1.5f)), 1.4f, 1e-4f);
}

TEST(FogField, DirectLightThroughASlabIsReducedByExpMinusTau) {
  Scene s = lit_floor();
  const RayScene clear(s);
  const C3f e0 = direct_irradiance(clear, V3f(0, 0, 0), V3f(0, 0, 1), 4, 1);
  ASSERT_GT(e0.x, 1.9f);  // the sun's irradiance, cos = 1

  s.volumes.push_back(slab(0.5f));
  RayScene foggy(s);
  foggy.set_medium(std::make_shared<FogField>(s, FogOptions{}));
  const C3f e = direct_irradiance(foggy, V3f(0, 0, 0), V3f(0, 0, 1), 4, 1);
  EXPECT_NEAR(e.x / e0.x, std::exp(-0.5f), 0.01f);
}

TEST(FogField, AnEmptyGridBehavesLikeNoFog) {
  Scene s = lit_floor();
  s.volumes.push_back(fog_box({0, 0, 0}, {0, 0, 0}, 0.f));  // no active voxel
  const auto field = std::make_shared<FogField>(s, FogOptions{});
  EXPECT_TRUE(field->empty());
  RayScene rays(s);
  rays.set_medium(field);
  EXPECT_EQ(rays.medium(), nullptr);
  const RayScene clear(lit_floor());
  EXPECT_EQ(direct_irradiance(rays, V3f(0, 0, 0), V3f(0, 0, 1), 4, 1),
            direct_irradiance(clear, V3f(0, 0, 0), V3f(0, 0, 1), 4, 1));
  FogPointStats stats;
  EXPECT_TRUE(bake_fog_points(s, 0.1f, FogOptions{}, &stats).empty());
  EXPECT_EQ(stats.points, 0u);
}

TEST(FogPoints, CoarserLevelsWhenTheSpacingAllows) {
  Scene s;
  s.volumes.push_back(fog_box({0, 0, 0}, {31, 31, 31}, 0.5f));  // 32^3 voxels: 4^3 leaf nodes
  FogPointStats st;
  VolumePoints fine = bake_fog_points(s, 0.05f, FogOptions{}, &st);  // below a voxel
  EXPECT_EQ(st.block_voxels, 1u);
  EXPECT_EQ(fine.points().size(), 32u * 32u * 32u);
  VolumePoints two = bake_fog_points(s, 0.25f, FogOptions{}, &st);
  EXPECT_EQ(st.block_voxels, 2u);
  EXPECT_EQ(two.points().size(), 16u * 16u * 16u);
  VolumePoints leaves = bake_fog_points(s, 0.8f, FogOptions{}, &st);  // leaf-node averages
  EXPECT_EQ(st.block_voxels, 8u);
  EXPECT_EQ(leaves.points().size(), 64u);
  for (const VolumePoint& p : leaves.points()) EXPECT_NEAR(p.sigma_t, 0.5f, 1e-5f);
  EXPECT_NEAR(leaves.block_size(), 0.8f, 1e-6f);
  // Capped by max_block_voxels.
  FogOptions capped;
  capped.max_block_voxels = 4;
  bake_fog_points(s, 10.f, capped, &st);
  EXPECT_EQ(st.block_voxels, 4u);
  // A leaf half full of fog averages to half the density.
  Scene half;
  half.volumes.push_back(fog_box({0, 0, 0}, {7, 7, 3}, 0.5f));
  VolumePoints h = bake_fog_points(half, 0.8f, FogOptions{}, &st);
  ASSERT_EQ(h.points().size(), 1u);
  EXPECT_NEAR(h.points()[0].sigma_t, 0.25f, 1e-5f);
}

TEST(FogPoints, SingleScatteringOfTheSunWithShadowTransmittance) {
  Scene s = lit_floor();
  s.volumes.push_back(fog_box({-8, -8, 10}, {7, 7, 25}, 1.f));  // z in [0.95, 2.55]
  const RayScene rays(s);
  FogOptions o;
  o.albedo = C3f(0.5f);
  const FogField field(s, o);
  VolumePoints pts = bake_fog_points(s, kVoxel, o);
  light_fog_points(rays, field, o, pts);
  // S = albedo / (4 pi) * E_sun * T(point -> top of the fog).
  int checked = 0;
  for (const VolumePoint& p : pts.points()) {
    const float depth = 2.55f - p.position.z;  // fog above the point
    const float expected = 0.5f * 2.f / (4.f * float(M_PI)) * std::exp(-depth);
    if (std::fabs(p.position.x) < 0.3f && std::fabs(p.position.y) < 0.3f) {
      EXPECT_NEAR(p.radiance.x, expected, 0.05f * expected + 1e-4f) << p.position.z;
      ++checked;
    }
  }
  EXPECT_GT(checked, 20);
}

// The gather: an emitting disk above the receiver, fog in between.

GatherResult gather_with(const test::SurfelTree& tree, std::shared_ptr<const VolumePoints> fog,
                         uint32_t resolution = GatherOptions{}.microbuffer_resolution) {
  GatherOptions o;
  o.microbuffer_resolution = resolution;
  Gatherer g(tree, o);
  g.set_volume_points(std::move(fog));
  return g.gather(Receiver{V3f(0, 0, 0), V3f(0, 0, 1)});
}

TEST(FogGather, IrradianceThroughAnAbsorbingSlabIsReducedByExpMinusTau) {
  std::vector<Surfel> surfels;
  test::add_disk(surfels, V3f(0, 0, 3), V3f(0, 0, -1), 0.4f, 400, C3f(1.f));
  const test::SurfelTree tree(surfels);
  const GatherResult clear = gather_with(tree, nullptr);
  ASSERT_GT(clear.irradiance.x, 0.01f);

  Scene s;
  s.volumes.push_back(slab(0.8f));
  const auto fog = std::make_shared<VolumePoints>(bake_fog_points(s, kVoxel, FogOptions{}));  // albedo: no light yet
  const GatherResult foggy = gather_with(tree, fog);
  // Near-vertical paths (the disk spans 7.6 degrees): tau = 0.8 / cos. At
  // the default N = 8 the fog is marched along pixel centres up to ~20
  // degrees off the disk's direction: a few percent too much extinction;
  // at N = 16 it is within 1%.
  EXPECT_NEAR(foggy.irradiance.x / clear.irradiance.x, std::exp(-0.8f), 0.05f);
  const float fine = gather_with(tree, fog, 16).irradiance.x / gather_with(tree, nullptr, 16).irradiance.x;
  EXPECT_NEAR(fine, std::exp(-0.8f), 0.01f);
  std::cout << "gather through a slab of tau 0.8: E ratio " << foggy.irradiance.x / clear.irradiance.x
            << " at N = 8, " << fine << " at N = 16 (exp(-tau) = " << std::exp(-0.8f) << ")\n";
  // An empty fog changes nothing.
  EXPECT_EQ(gather_with(tree, std::make_shared<VolumePoints>()).irradiance, clear.irradiance);
}

TEST(FogGather, TheFactorizedGatherSeesTheFogToo) {
  std::vector<Surfel> surfels;
  test::add_disk(surfels, V3f(0, 0, 3), V3f(0, 0, -1), 0.4f, 400, C3f(1.f));
  const test::SurfelTree tree(surfels);
  Scene s;
  s.volumes.push_back(slab(0.8f));
  const auto fog = std::make_shared<VolumePoints>(bake_fog_points(s, kVoxel, FogOptions{}));
  GatherOptions o;
  o.method = GatherMethod::kFpbgi;
  std::vector<Receiver> receivers;
  for (int i = 0; i < 16; ++i) receivers.push_back({V3f(0.01f * float(i % 4), 0.01f * float(i / 4), 0.f), V3f(0, 0, 1)});
  std::vector<GatherResult> clear(receivers.size()), foggy(receivers.size());
  Gatherer a(tree, o), b(tree, o);
  b.set_volume_points(fog);
  a.gather_tile(receivers, clear);
  b.gather_tile(receivers, foggy);
  for (size_t i = 0; i < receivers.size(); ++i) {
    ASSERT_GT(clear[i].irradiance.x, 0.01f);
    EXPECT_NEAR(foggy[i].irradiance.x / clear[i].irradiance.x, std::exp(-0.8f), 0.05f) << i;
  }
}

TEST(FogGather, AmbientOcclusionBehindADenseFogCubeIsBelowOne) {
  const test::SurfelTree empty_tree(std::vector<Surfel>{});
  EXPECT_EQ(gather_with(empty_tree, nullptr).ao, 1.f);
  Scene s;
  s.volumes.push_back(fog_box({-5, -5, 5}, {5, 5, 15}, 20.f));  // a 1.1 m cube, 0.45 m above
  const auto fog = std::make_shared<VolumePoints>(bake_fog_points(s, kVoxel, FogOptions{}));
  const GatherResult r = gather_with(empty_tree, fog);
  // Opaque: it hides about the cosine-weighted solid angle it subtends.
  std::cout << "AO under a dense fog cube: " << r.ao << "\n";
  EXPECT_LT(r.ao, 0.8f);
  EXPECT_GT(r.ao, 0.1f);
  EXPECT_EQ(r.irradiance, C3f(0.f));  // unlit fog emits nothing
}

}  // namespace
}  // namespace pbgi
