// Single scattering of direct light in fog: the reference path tracer's
// in-scattered light against the analytic integral for a homogeneous slab,
// nothing for a black albedo, and PBGI's fog points (the gather) against
// the reference on the same scene.
//
// Scene: a floor at z = 0 (albedo 0.5, nothing else to reflect), a sun
// straight above (irradiance E), and a slab of fog sigma_t = 1 from
// z0 = 0.025 to z1 = 0.525 (D = 0.5), 40 m wide so that directions from the
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
#include "tests/server/gather/surfel_tree.h"
#include "tests/server/volumes/constant_fog.h"

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <memory>
#include <numeric>

namespace pbgi {
namespace {

constexpr float kVoxel = 0.05f;
constexpr float kSigma = 1.f;
constexpr float kZ0 = 0.025f, kZ1 = 0.525f;  // the slab's faces (voxel bounds)
constexpr float kSun = 2.f;                // irradiance
constexpr float kFloorAlbedo = 0.5f;

Scene sunlit_slab() {
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

  // Voxel k is centred at k x kVoxel: indices 1..10 are z in [0.025,
  // 0.525) (trilinear: full density from 0.05 to 0.5, ramps to 0 at 0 and
  // 0.55, optical depth 0.5 straight through), x, y in [-20.025, 19.975).
  s.volumes.push_back(test::constant_fog(openvdb::CoordBBox({-400, -400, 1}, {399, 399, 10}), kVoxel, kSigma));
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

// The slab scene, its fog (of the given albedo) as the rays' medium.
struct FoggyFloor {
  explicit FoggyFloor(float albedo) : scene(sunlit_slab()), rays(scene) {
    fog.albedo = C3f(albedo);
    field = std::make_shared<const FogField>(scene, fog);
    rays.set_medium(field);
  }
  // The reference's view of the floor.
  ReferenceImage reference() const {
    ReferenceOptions ro;
    ro.width = ro.height = 16;
    ro.spp = 256;
    ro.max_depth = 1;
    return render_reference(rays, scene.cameras.at("/Cam"), ro);
  }

  Scene scene;
  FogOptions fog;
  RayScene rays;
  std::shared_ptr<const FogField> field;
};

// The scattering distances' defining property (participating_medium.h),
// E[weight * g(t)] = integral of sigma_t T g, for g = 1 (then 1 - T of the
// whole segment) and g = [t < half the slab] (1 - T up to there), with one
// grid and with two overlapping grids of half the density each.
TEST(FogScattering, ScatteringDistancesFollowSigmaTTimesTransmittance) {
  const openvdb::CoordBBox slab({-20, -20, 1}, {19, 19, 10});  // z in [0.025, 0.525)
  Scene one, two;
  one.volumes.push_back(test::constant_fog(slab, kVoxel, 1.2f));
  two.volumes.push_back(test::constant_fog(slab, kVoxel, 0.6f, "/FogA"));
  two.volumes.push_back(test::constant_fog(slab, kVoxel, 0.6f, "/FogB"));
  const V3f origin(0.1f, 0.2f, -1.f), up(0.f, 0.f, 1.f);
  for (const Scene* s : {&one, &two}) {
    const FogField field(*s, FogOptions{});
    const float half = 1.f + 0.5f * (kZ0 + kZ1);  // t at the slab's middle
    // Midpoints of 8 x 1024 strata of (u_pick, u_distance): the
    // indicator's error is at most one stratum's mass, < 5e-4.
    constexpr int picks = 8, distances = 1024;
    double all = 0, below_half = 0;
    for (int i = 0; i < picks; ++i)
      for (int j = 0; j < distances; ++j) {
        const MediumScatter m =
            field.sample_scatter(origin, up, 0.f, INFINITY, (i + 0.5f) / picks, (j + 0.5f) / distances);
        all += m.weight;
        below_half += m.t < half ? m.weight : 0.f;
      }
    all /= picks * distances;
    below_half /= picks * distances;
    EXPECT_NEAR(all, 1.0 - field.transmittance(origin, up, 0.f, INFINITY), 1e-3) << s->volumes.size();
    EXPECT_NEAR(below_half, 1.0 - field.transmittance(origin, up, 0.f, half), 1e-3) << s->volumes.size();
  }
}

TEST(FogScattering, ReferenceMatchesTheSingleScatteringIntegralOfASunlitSlab) {
  const FoggyFloor f(0.8f);
  const ReferenceImage ref = f.reference();
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
  const ReferenceImage ref = FoggyFloor(0.f).reference();
  EXPECT_EQ(mean(ref.indirect), 0.f);
  EXPECT_GT(mean(ref.direct), 0.f);
}

// ReferenceOptions::fog_on_camera_rays: a camera just above the floor
// looking up at 45 degrees through the slab into an empty sky sees only the
// light the fog scatters along its rays, L(mu) of the top of this file with
// mu = cos 45 degrees (the same integral read from the other end: the path
// through the slab and the sun's light at each point); without the option,
// nothing.
TEST(FogScattering, CameraRaysSeeTheSlabsScatteredLightWhenAsked) {
  const FoggyFloor f(0.8f);
  Camera up;
  up.local_to_world.setAxisAngle(V3f(1, 0, 0), float(M_PI) * 0.75f);  // -Z -> (0, 0.71, 0.71)
  up.local_to_world *= M44f().setTranslation(V3f(0, 0, 0.002f));
  up.focal_length = 100.f;
  up.horizontal_aperture = up.vertical_aperture = 1.f;  // rays within 0.3 degrees of the axis
  up.near_clip = 1e-4f;
  ReferenceOptions ro;
  ro.width = ro.height = 4;
  ro.spp = 64;
  ro.max_depth = 1;
  ro.fog_on_camera_rays = true;
  const ReferenceImage seen = render_reference(f.rays, up, ro);
  const double mu = std::sqrt(0.5), d = kZ1 - kZ0;
  const double expected =
      0.8 * kSun / (4.0 * M_PI) * (std::exp(-kSigma * d) - std::exp(-kSigma * d / mu)) / (1.0 - mu);
  std::cout << "camera ray up through the slab at 45 degrees: analytic " << expected << ", reference "
            << mean(seen.direct) << "\n";
  EXPECT_NEAR(mean(seen.direct), expected, 0.02 * expected);
  EXPECT_EQ(mean(seen.indirect), 0.f);
  ro.fog_on_camera_rays = false;
  EXPECT_EQ(mean(render_reference(f.rays, up, ro).direct), 0.f);
}

// PBGI's fog contribution (fog points lit by single scattering, composited
// by the gather into the floor's irradiance) against the reference's.
TEST(FogScattering, PbgiFogPointsAgreeWithTheReference) {
  const FoggyFloor f(0.8f);
  const ReferenceImage ref = f.reference();
  const test::SurfelTree empty(std::vector<Surfel>{});
  Gatherer g(empty, GatherOptions{});
  auto points = std::make_shared<VolumePoints>(bake_fog_points(f.scene, 0.2f, f.fog));
  light_fog_points(f.rays, *f.field, f.fog, *points);
  g.set_volume_points(points);
  const GatherResult r = g.gather(Receiver{V3f(0, 0, 0.001f), V3f(0, 0, 1)});
  const float pbgi = kFloorAlbedo / float(M_PI) * r.irradiance.x;
  std::cout << "sunlit slab: floor indirect PBGI " << pbgi << ", reference " << mean(ref.indirect) << "\n";
  EXPECT_NEAR(pbgi, mean(ref.indirect), 0.03f * mean(ref.indirect));
}

}  // namespace
}  // namespace pbgi
