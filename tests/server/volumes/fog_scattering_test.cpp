// Single scattering of direct light in fog: the reference path tracer's
// in-scattered light against the analytic integral for a homogeneous slab,
// nothing for a black albedo, and PBGI's fog points (the gather) against
// the reference on the same scene.
//
// Scene: a floor at z = 0 (albedo 0.5, nothing else to reflect), a sun
// straight above (irradiance E), and a slab of fog sigma_t = 1 between
// z0 = 0.05 and z1 = 0.55 (D = 0.5), 40 m wide so that directions from the
// floor's centre leave through its top down to 1.5 degrees of elevation.
// The camera looks straight down at the floor from inside the slab (camera
// rays see no fog, in the reference as in the daemon), so the floor's
// indirect AOV is the in-scattered light alone:
//   L_in(mu) = albedo_f E / (4 pi) (exp(-sigma D) - exp(-sigma D / mu)) / (1 - mu)
// along a direction of cosine mu (integrating sigma exp(-sigma s) over the
// path, times the sun's exp(-sigma (z1 - z)) at each point), and
//   indirect = albedo_floor / pi * 2 pi * integral_0^1 L_in(mu) mu dmu.
#include "server/gather/gather.h"
#include "server/reference/path_tracer.h"
#include "server/volumes/fog_field.h"
#include "server/volumes/fog_points.h"
#include "server/volumes/volume_grid.h"
#include "tests/server/gather/surfel_tree.h"

#include <openvdb/openvdb.h>

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <numeric>

namespace pbgi {
namespace {

constexpr float kVoxel = 0.05f;
constexpr float kSigma = 1.f;
constexpr float kZ0 = 0.05f, kZ1 = 0.55f;  // the slab's faces (voxel bounds)
constexpr float kSun = 2.f;                // irradiance
constexpr float kFloorAlbedo = 0.5f;

Scene sunlit_slab() {
  openvdb::initialize();
  Scene s;
  s.source_path = "fog_scattering_test";
  s.materials.resize(1);
  s.materials[0].albedo = C3f(kFloorAlbedo);
  s.triangles.positions = {{-50, -50, 0}, {50, -50, 0}, {50, 50, 0}, {-50, 50, 0}};
  s.triangles.indices = {0, 1, 2, 0, 2, 3};
  s.triangles.material = {0, 0};
  Light sun;
  sun.kind = LightKind::Distant;
  sun.radiance = C3f(kSun);
  sun.angle_degrees = 0.5f;
  s.lights.push_back(sun);
  Camera cam;  // looks down -Z at a 0.1 m square of floor
  cam.prim_path = "/Cam";
  cam.local_to_world.setTranslation(V3f(0, 0, 0.1f));
  cam.focal_length = 20.f;
  cam.horizontal_aperture = cam.vertical_aperture = 20.f;
  s.cameras[cam.prim_path] = cam;

  // Voxel k covers [k - 0.5, k + 0.5) x kVoxel: indices 1..10 are z in
  // [0.05, 0.55), and x, y in [-20, 20).
  openvdb::FloatGrid::Ptr grid = openvdb::FloatGrid::create(0.f);
  grid->setTransform(openvdb::math::Transform::createLinearTransform(kVoxel));
  grid->fill(openvdb::CoordBBox({-400, -400, 1}, {399, 399, 10}), kSigma, true);
  Volume v;
  v.prim_path = "/Fog";
  v.kind = VolumeKind::Fog;
  v.voxel_size = kVoxel;
  v.grid = std::make_shared<VolumeGrid>(grid);
  v.bounds = Box3f(V3f(-20.025f, -20.025f, kZ0), V3f(19.975f, 19.975f, kZ1));
  s.volumes.push_back(v);
  return s;
}

// The floor's indirect radiance from the in-scattered light (top of file),
// by the midpoint rule in mu.
double analytic_floor_indirect(double fog_albedo) {
  const double d = kZ1 - kZ0;
  const int n = 200000;
  double integral = 0.0;
  for (int i = 0; i < n; ++i) {
    const double mu = (i + 0.5) / n;
    const double l = fog_albedo * kSun / (4.0 * M_PI) * (std::exp(-kSigma * d) - std::exp(-kSigma * d / mu)) /
                     (1.0 - mu);
    integral += l * mu / n;
  }
  return kFloorAlbedo / M_PI * 2.0 * M_PI * integral;
}

float mean(const std::vector<float>& v) { return std::accumulate(v.begin(), v.end(), 0.f) / float(v.size()); }

ReferenceImage render(const RayScene& rays, const Scene& s) {
  ReferenceOptions ro;
  ro.width = ro.height = 16;
  ro.spp = 256;
  ro.max_depth = 1;
  return render_reference(rays, s.cameras.at("/Cam"), ro);
}

TEST(FogScattering, ReferenceMatchesTheSingleScatteringIntegralOfASunlitSlab) {
  const Scene s = sunlit_slab();
  FogOptions fog;
  fog.albedo = C3f(0.8f);
  RayScene rays(s);
  rays.set_medium(std::make_shared<FogField>(s, fog));
  const ReferenceImage ref = render(rays, s);
  const double expected = analytic_floor_indirect(0.8);
  std::cout << "sunlit slab (tau 0.5, albedo 0.8): floor indirect analytic " << expected << ", reference "
            << mean(ref.indirect) << "\n";
  EXPECT_NEAR(mean(ref.indirect), expected, 0.01 * expected);
  // One scattering event: all of it is in the one-bounce AOV.
  EXPECT_EQ(mean(ref.indirect1), mean(ref.indirect));
  // Direct light still crosses the whole slab.
  EXPECT_NEAR(mean(ref.direct), kFloorAlbedo / M_PI * kSun * std::exp(-kSigma * (kZ1 - kZ0)),
              0.01 * kFloorAlbedo / M_PI * kSun);
}

TEST(FogScattering, ABlackAlbedoScattersNothing) {
  const Scene s = sunlit_slab();
  FogOptions fog;
  fog.albedo = C3f(0.f);
  RayScene rays(s);
  rays.set_medium(std::make_shared<FogField>(s, fog));
  const ReferenceImage ref = render(rays, s);
  EXPECT_EQ(mean(ref.indirect), 0.f);
  EXPECT_GT(mean(ref.direct), 0.f);
}

// PBGI's fog contribution (fog points lit by single scattering, composited
// by the gather into the floor's irradiance) against the reference's.
TEST(FogScattering, PbgiFogPointsAgreeWithTheReference) {
  const Scene s = sunlit_slab();
  FogOptions fog;
  fog.albedo = C3f(0.8f);
  RayScene rays(s);
  const auto field = std::make_shared<FogField>(s, fog);
  rays.set_medium(field);
  const ReferenceImage ref = render(rays, s);

  const test::SurfelTree empty(std::vector<Surfel>{});
  Gatherer g(empty, GatherOptions{});
  auto points = std::make_shared<VolumePoints>(bake_fog_points(s, 0.2f, fog));
  light_fog_points(rays, *field, fog, *points);
  g.set_volume_points(points);
  const GatherResult r = g.gather(Receiver{V3f(0, 0, 0.001f), V3f(0, 0, 1)});
  const float pbgi = kFloorAlbedo / float(M_PI) * r.irradiance.x;
  std::cout << "sunlit slab: floor indirect PBGI " << pbgi << ", reference " << mean(ref.indirect) << "\n";
  EXPECT_NEAR(pbgi, mean(ref.indirect), 0.03f * mean(ref.indirect));
}

}  // namespace
}  // namespace pbgi
