// PBGI against the reference path tracer under a fog slab: the floor's
// direct light (shadow rays through FogField in both) and its ambient
// occlusion (PBGI: the gather's fog fragments; reference: transmittance of
// its AO rays) agree within their bounds.
#include "server/gather/gather.h"
#include "server/reference/path_tracer.h"
#include "server/scene/direct_lighting.h"
#include "server/volumes/fog_field.h"
#include "server/volumes/fog_points.h"
#include "server/volumes/volume_grid.h"
#include "tests/server/gather/surfel_tree.h"
#include "tests/server/volumes/constant_fog.h"

#include <openvdb/openvdb.h>

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <numeric>

namespace pbgi {
namespace {

constexpr float kVoxel = 0.1f;
constexpr float kDensity = 0.5f;  // tau = 0.5 straight up through the 1 m slab

// A floor at z = 0 (albedo 0.5), a sun straight above, and an absorbing
// fog slab z in [0.95, 1.95], |x|, |y| < 20 (wide: AO rays cross it).
Scene foggy_floor() {
  Scene s;
  s.source_path = "fog_reference_test";
  s.materials.resize(1);
  s.materials[0].albedo = C3f(0.5f);
  s.triangles.positions = {{-50, -50, 0}, {50, -50, 0}, {50, 50, 0}, {-50, 50, 0}};
  s.triangles.indices = {0, 1, 2, 0, 2, 3};
  s.triangles.material = {0, 0};
  Light sun;
  sun.kind = LightKind::Distant;
  sun.radiance = C3f(2.f);
  sun.angle_degrees = 0.5f;
  s.lights.push_back(sun);
  Camera cam;  // looks down -Z from below the fog at the floor
  cam.prim_path = "/Cam";
  cam.local_to_world.setTranslation(V3f(0, 0, 0.5f));
  cam.horizontal_aperture = cam.vertical_aperture = 2.f;
  s.cameras[cam.prim_path] = cam;

  // Voxels z 10..19 of 0.1: the slab z in [0.95, 1.95].
  s.volumes.push_back(test::constant_fog(openvdb::CoordBBox({-200, -200, 10}, {199, 199, 19}), kVoxel, kDensity));
  return s;
}

float mean(const std::vector<float>& v) { return std::accumulate(v.begin(), v.end(), 0.f) / float(v.size()); }

TEST(FogReference, DirectLightAndAmbientOcclusionUnderAFogSlab) {
  const Scene s = foggy_floor();
  FogOptions fog;
  fog.albedo = C3f(0.f);  // absorbing (fog_scattering_test.cpp checks scattering)
  RayScene rays(s);
  const auto field = std::make_shared<FogField>(s, fog);
  rays.set_medium(field);

  ReferenceOptions ro;
  ro.width = ro.height = 8;
  ro.spp = 256;
  ro.max_depth = 1;
  const ReferenceImage ref = render_reference(rays, s.cameras.at("/Cam"), ro);

  // Direct: the reference's floor radiance, the daemon's shadow rays and
  // exp(-tau) agree.
  const float expected = 0.5f / float(M_PI) * 2.f * std::exp(-kDensity);
  const C3f e = direct_irradiance(rays, V3f(0, 0, 0), V3f(0, 0, 1), 4, 1);
  EXPECT_NEAR(0.5f / float(M_PI) * e.x, expected, 0.01f * expected);
  EXPECT_NEAR(mean(ref.direct), expected, 0.02f * expected);

  // AO: the cosine-weighted mean transmittance through the slab,
  // 2 E3(0.5) = 0.4432 for an infinite slab (the slab's edges let a little
  // more through at grazing angles).
  const float ref_ao = mean(ref.ao);
  EXPECT_NEAR(ref_ao, 0.4432f, 0.02f);
  const test::SurfelTree empty(std::vector<Surfel>{});
  Gatherer g(empty, GatherOptions{});
  auto points = std::make_shared<VolumePoints>(bake_fog_points(s, 0.2f, fog));
  light_fog_points(rays, *field, fog, *points);
  g.set_volume_points(points);
  const GatherResult r = g.gather(Receiver{V3f(0, 0, 0.001f), V3f(0, 0, 1)});
  EXPECT_NEAR(r.ao, ref_ao, 0.03f);
  std::cout << "fog slab tau " << kDensity << ": direct expected " << expected << ", daemon "
            << 0.5f / float(M_PI) * e.x << ", reference " << mean(ref.direct) << "; AO reference " << ref_ao
            << ", PBGI " << r.ao << "\n";
  EXPECT_EQ(r.irradiance, C3f(0.f));  // absorbing fog sends no light
}

}  // namespace
}  // namespace pbgi
