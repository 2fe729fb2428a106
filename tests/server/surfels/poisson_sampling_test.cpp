// Poisson-disk sampling: minimum distance (also across triangle edges and
// tile boundaries), coverage, exact area, camera-adaptive density, and the
// streaming generation equal to sampling + shading in memory.
#include "common/errors.h"
#include "server/scene/ray_scene.h"
#include "server/surfels/surfels.h"
#include "tests/server/scene/test_scenes.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numeric>
#include <unordered_map>

namespace pbgi {
namespace {

// A square [0, size]^2 at z = z0 as a grid of n x n quads (2n^2 triangles).
void add_tessellated_plane(Scene& s, float size, int n, float z0, uint32_t material, bool down = false) {
  TriangleSoup& t = s.triangles;
  const uint32_t mesh = static_cast<uint32_t>(t.mesh_paths.size());
  t.mesh_paths.push_back("/plane" + std::to_string(mesh));
  t.double_sided.push_back(0);
  const uint32_t base = static_cast<uint32_t>(t.positions.size());
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) t.positions.push_back(V3f(size * i / n, size * j / n, z0));
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      const uint32_t a = base + j * (n + 1) + i, b = a + 1, c = a + n + 1, d = c + 1;
      if (down) {
        t.indices.insert(t.indices.end(), {a, c, d, a, d, b});
      } else {
        t.indices.insert(t.indices.end(), {a, b, d, a, d, c});
      }
      t.material.insert(t.material.end(), {material, material});
      t.mesh.insert(t.mesh.end(), {mesh, mesh});
    }
  }
}

double area_of(const std::vector<Surfel>& v) {
  return std::accumulate(v.begin(), v.end(), 0.0, [](double a, const Surfel& s) { return a + s.area(); });
}

// Nearest-neighbour queries over surfel positions (a uniform hash grid).
class PointGrid {
 public:
  PointGrid(const std::vector<Surfel>& s, float cell) : s_(s), cell_(cell) {
    for (uint32_t i = 0; i < s.size(); ++i) cells_[key(s[i].position)].push_back(i);
  }
  // Distance from p to the nearest surfel other than `self`, searched
  // within `reach` cells.
  float nearest(const V3f& p, int64_t self = -1, int reach = 2) const {
    float best = INFINITY;
    const int64_t cx = int64_t(std::floor(p.x / cell_)), cy = int64_t(std::floor(p.y / cell_)),
                  cz = int64_t(std::floor(p.z / cell_));
    for (int64_t z = cz - reach; z <= cz + reach; ++z)
      for (int64_t y = cy - reach; y <= cy + reach; ++y)
        for (int64_t x = cx - reach; x <= cx + reach; ++x) {
          const auto it = cells_.find(pack(x, y, z));
          if (it == cells_.end()) continue;
          for (uint32_t i : it->second)
            if (int64_t(i) != self) best = std::min(best, (s_[i].position - p).length());
        }
    return best;
  }

 private:
  static uint64_t pack(int64_t x, int64_t y, int64_t z) {
    return uint64_t(x + (1 << 20)) | uint64_t(y + (1 << 20)) << 21 | uint64_t(z + (1 << 20)) << 42;
  }
  uint64_t key(const V3f& p) const {
    return pack(int64_t(std::floor(p.x / cell_)), int64_t(std::floor(p.y / cell_)), int64_t(std::floor(p.z / cell_)));
  }
  const std::vector<Surfel>& s_;
  float cell_;
  std::unordered_map<uint64_t, std::vector<uint32_t>> cells_;
};

SurfelOptions poisson(float spacing) {
  SurfelOptions o;
  o.sampler = SurfelSampler::kPoisson;
  o.spacing = spacing;
  return o;
}

TEST(PoissonSampling, MinimumDistanceCoverageAndAreaOnAPlane) {
  // 900 triangles: most neighbours lie across a triangle edge.
  Scene s;
  const uint32_t m = test::add_material(s, {0.5f, 0.5f, 0.5f});
  add_tessellated_plane(s, 10.f, 15, 0.f, m);
  const float spacing = 0.1f;
  const auto surfels = sample_surfels(s, poisson(spacing));
  // About one surfel per spacing^2.
  EXPECT_NEAR(surfels.size() / 10000.0, 1.0, 0.15) << surfels.size();
  // Area is conserved exactly.
  EXPECT_NEAR(area_of(surfels), 100.0, 1e-3);
  // No two closer than 0.7 x spacing (the sampler's radius is 0.75 x).
  const PointGrid grid(surfels, spacing);
  float min_nn = INFINITY;
  for (size_t i = 0; i < surfels.size(); ++i) min_nn = std::min(min_nn, grid.nearest(surfels[i].position, i));
  EXPECT_GT(min_nn, 0.7f * spacing);
  // Coverage: every point of the plane has a surfel within 1.25 spacings
  // (no holes, also along triangle edges; a maximal Poisson-disk set leaves
  // gaps up to its radius plus the candidate lattice's step).
  float max_gap = 0;
  for (int j = 0; j <= 200; ++j)
    for (int i = 0; i <= 200; ++i) max_gap = std::max(max_gap, grid.nearest(V3f(0.05f * i, 0.05f * j, 0), -1, 3));
  EXPECT_LT(max_gap, 1.25f * spacing);
  std::printf("%zu surfels, min distance %.3f x spacing, largest gap %.3f x spacing\n", surfels.size(),
              min_nn / spacing, max_gap / spacing);
  // Radii: the disk of the area each stands for, about spacing^2.
  for (const Surfel& x : surfels) {
    EXPECT_GT(x.area(), 0.1f * spacing * spacing);
    EXPECT_LT(x.area(), 3.f * spacing * spacing);
    EXPECT_EQ(x.normal, V3f(0, 0, 1));
  }
}

TEST(PoissonSampling, MinimumDistanceHoldsAcrossTiles) {
  // ~90k surfels: several tiles of the sampler's octree.
  Scene s;
  const uint32_t m = test::add_material(s, {0.5f, 0.5f, 0.5f});
  add_tessellated_plane(s, 300.f, 4, 0.f, m);
  test::add_quad(s, V3f(0, 0, 0), V3f(0, 300, 0), V3f(0, 300, 20), V3f(0, 0, 20), m, "/wall");  // a corner
  const auto surfels = sample_surfels(s, poisson(1.f));
  EXPECT_GT(surfels.size(), 80000u);
  const PointGrid grid(surfels, 1.f);
  float min_nn = INFINITY;
  for (size_t i = 0; i < surfels.size(); ++i) min_nn = std::min(min_nn, grid.nearest(surfels[i].position, i, 1));
  EXPECT_GT(min_nn, 0.7f);
  EXPECT_NEAR(area_of(surfels), 300.0 * 300.0 + 300.0 * 20.0, 1.0);
}

TEST(PoissonSampling, ThinWallFacesAreSampledIndependently) {
  // Two faces 1 mm apart, back to back: each gets its own full sampling.
  Scene s;
  const uint32_t m = test::add_material(s, {0.5f, 0.5f, 0.5f});
  add_tessellated_plane(s, 4.f, 2, 0.f, m);
  add_tessellated_plane(s, 4.f, 2, -0.001f, m, /*down=*/true);
  const auto surfels = sample_surfels(s, poisson(0.1f));
  size_t up = 0, down = 0;
  for (const Surfel& x : surfels) (x.normal.z > 0 ? up : down)++;
  EXPECT_NEAR(up / 1600.0, 1.0, 0.15);
  EXPECT_NEAR(down / 1600.0, 1.0, 0.15);
  EXPECT_NEAR(area_of(surfels), 32.0, 1e-3);
}

// Coincident coplanar copies (a duplicated mesh, or a second mesh laid over
// part of the first) are one surface: the surfels stand for its area once,
// at the usual density. Before the fix every copy's area was handed to the
// surfels of the union (a doubled quad had twice its area).
TEST(PoissonSampling, CoincidentCoplanarCopiesCountTheirAreaOnce) {
  Scene s;
  const uint32_t m = test::add_material(s, {0.5f, 0.5f, 0.5f});
  add_tessellated_plane(s, 4.f, 2, 0.f, m);   // 16 units^2 in 8 triangles
  add_tessellated_plane(s, 4.f, 3, 0.f, m);   // the same plane, other triangles
  test::add_quad(s, V3f(0, 0, 0), V3f(4, 0, 0), V3f(4, 4, 0), V3f(0, 4, 0), m, "/copy");  // a third
  // A fourth, partial: x in [1, 2.5], y in [0.5, 3.5].
  test::add_quad(s, V3f(1, 0.5f, 0), V3f(2.5f, 0.5f, 0), V3f(2.5f, 3.5f, 0), V3f(1, 3.5f, 0), m, "/part");
  // The face of a thin wall behind it (opposite normal) is not a copy.
  add_tessellated_plane(s, 4.f, 2, 0.f, m, /*down=*/true);
  const float spacing = 0.1f;
  const auto surfels = sample_surfels(s, poisson(spacing));
  double up_area = 0, down_area = 0, inside_part = 0;
  size_t up = 0;
  for (const Surfel& x : surfels) {
    if (x.normal.z > 0) {
      up_area += x.area();
      ++up;
      const V3f& p = x.position;
      if (p.x > 1.2f && p.x < 2.3f && p.y > 0.7f && p.y < 3.3f) inside_part += x.area();
    } else {
      down_area += x.area();
    }
  }
  std::printf("coincident copies: up area %.4f (one copy 16), down %.4f, %zu up surfels\n", up_area,
              down_area, up);
  EXPECT_NEAR(up_area, 16.0, 0.01 * 16.0);
  EXPECT_NEAR(down_area, 16.0, 1e-3);
  // The same density as a single plane (1600), and the same area per unit
  // area where four copies overlap as elsewhere.
  EXPECT_NEAR(up / 1600.0, 1.0, 0.15);
  EXPECT_NEAR(inside_part / (1.1 * 2.6), 1.0, 0.1);
}

TEST(PoissonSampling, DoubleSidedTwinsAndTinyMeshes) {
  Scene s;
  const uint32_t m = test::add_material(s, {0.5f, 0.5f, 0.5f});
  test::add_quad(s, V3f(0, 0, 0), V3f(1, 0, 0), V3f(1, 1, 0), V3f(0, 1, 0), m, "/sheet", true);
  test::add_square_z(s, 5, 5, 1, 0.005f, m, false, "/speck");  // far below the spacing
  SurfelOptions o = poisson(0.1f);
  const auto surfels = sample_surfels(s, o);
  size_t up = 0, down = 0, speck = 0;
  for (const Surfel& x : surfels) {
    if (x.position.z == 1.f) {
      ++speck;
      EXPECT_NEAR(x.area(), 1e-4f, 1e-7f);
      continue;
    }
    (x.normal.z > 0 ? up : down)++;
  }
  EXPECT_EQ(up, down);
  EXPECT_EQ(speck, 1u);
  EXPECT_NEAR(area_of(surfels), 2.0 + 1e-4, 1e-4);
}

TEST(PoissonSampling, DeterministicForASeed) {
  Scene s;
  const uint32_t m = test::add_material(s, {0.5f, 0.5f, 0.5f});
  add_tessellated_plane(s, 5.f, 7, 0.f, m);
  const auto a = sample_surfels(s, poisson(0.1f));
  const auto b = sample_surfels(s, poisson(0.1f));
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) ASSERT_EQ(a[i].position, b[i].position) << i;
  SurfelOptions o = poisson(0.1f);
  o.seed = 9;
  const auto c = sample_surfels(s, o);
  EXPECT_TRUE(c.size() != a.size() || c[0].position != a[0].position);
}

// Ground y = 0 for z in [-100, 20], x in [-30, 30]; a camera at (0, 3, 0)
// looking along -Z (USD cameras look down their local -Z) tilted 13 degrees
// down, 20.955 mm aperture and 50 mm focal length: half fields of view of
// atan(0.21) = 11.9 degrees on a square image, so the ground is on screen
// from z = -6 to beyond z = -40 (and off screen behind the camera).
Scene ground_and_camera() {
  Scene s;
  const uint32_t m = test::add_material(s, {0.5f, 0.5f, 0.5f});
  test::add_quad(s, V3f(-30, 0, 20), V3f(30, 0, 20), V3f(30, 0, -100), V3f(-30, 0, -100), m, "/ground");
  Camera cam;
  cam.prim_path = "/cam";
  // Rows: the images of the local axes (USD row vectors, p' = p * M).
  const float t = 13.f * float(M_PI) / 180.f, sn = std::sin(t), cs = std::cos(t);
  cam.local_to_world = M44f(1, 0, 0, 0, 0, cs, -sn, 0, 0, sn, cs, 0, 0, 3, 0, 1);
  s.cameras["/cam"] = cam;
  return s;
}

// Surfels per unit area in x in [x0, x1], z in [z0, z1].
double density(const std::vector<Surfel>& v, float x0, float x1, float z0, float z1) {
  size_t n = 0;
  for (const Surfel& s : v)
    if (s.position.x >= x0 && s.position.x < x1 && s.position.z >= z0 && s.position.z < z1) ++n;
  return double(n) / ((x1 - x0) * (z1 - z0));
}

TEST(PoissonSampling, CameraAdaptiveDensityFallsOffWithDistance) {
  const Scene s = ground_and_camera();
  SurfelOptions o;
  o.sampler = SurfelSampler::kPoisson;
  o.camera = "/cam";
  o.image_width = 160;
  o.image_height = 160;
  o.pixel_footprint = 8.f;
  o.offscreen_factor = 4.f;
  const auto surfels = sample_surfels(s, o);
  ASSERT_GT(surfels.size(), 1000u);
  EXPECT_NEAR(area_of(surfels), 60.0 * 120.0, 1.0);

  // Spacing h = d * (aperture / focal / width) * footprint = 0.021 d, so
  // the density ~ 1 / h^2 falls as 1 / d^2.
  const float per_distance = 20.955f / 50.f / 160.f * 8.f;
  auto expected = [&](float z) {
    const float d = std::sqrt(z * z + 9.f);
    return 1.0 / std::pow(d * per_distance, 2.f);
  };
  const double near = density(surfels, -1, 1, -10, -6);   // on screen, d ~ 8.5
  const double far = density(surfels, -2, 2, -44, -36);   // on screen, d ~ 40
  std::printf("%zu surfels; per unit area: %.1f at z = -8 (expected ~%.1f), %.2f at z = -40 (expected ~%.2f)\n",
              surfels.size(), near, expected(-8), far, expected(-40));
  EXPECT_NEAR(near / expected(-8), 1.0, 0.35);
  EXPECT_NEAR(far / expected(-40), 1.0, 0.35);
  EXPECT_GT(near, 12 * far);  // (40 / 8.5)^2 = 22

  // Behind the camera (off screen) the same distance gets offscreen_factor
  // times the spacing: 16x fewer surfels.
  const double behind = density(surfels, -2, 2, 6, 10);
  EXPECT_GT(near, 8 * behind);
  EXPECT_LT(near, 32 * behind);

  // Locally still a Poisson-disk set: nearest neighbours at >= 0.7 h.
  const PointGrid grid(surfels, 0.2f);
  size_t checked = 0;
  for (size_t i = 0; i < surfels.size(); ++i) {
    const V3f& p = surfels[i].position;
    if (p.z > -4 || std::abs(p.x) > 0.2f * -p.z) continue;  // on screen only
    const float h = (p - V3f(0, 3, 0)).length() * per_distance;
    if (h > 0.4f) continue;  // the grid searches 2 cells around
    ++checked;
    EXPECT_GT(grid.nearest(p, i), 0.69f * h) << p;
  }
  EXPECT_GT(checked, 100u);
}

TEST(PoissonSampling, BadCameraOptionsAreRefused) {
  const Scene s = ground_and_camera();
  SurfelOptions o;
  o.camera = "/cam";  // uniform sampler: refused
  EXPECT_THROW(o.validate(), InvalidArgument);
  o.sampler = SurfelSampler::kPoisson;
  o.camera = "/nope";
  EXPECT_THROW(sample_surfels(s, o), InvalidArgument);
  o.camera = "/cam";
  o.pixel_footprint = 0;
  EXPECT_THROW(o.validate(), InvalidArgument);
}

class GenerateSurfels : public ::testing::TestWithParam<SurfelSampler> {};

TEST_P(GenerateSurfels, StreamedBatchesEqualSamplingThenShading) {
  Scene s;
  const uint32_t white = test::add_material(s, {0.8f, 0.8f, 0.8f});
  add_tessellated_plane(s, 4.f, 3, 0.f, white);
  s.lights.push_back(test::rect_light(2, 2, 2, 1, 1, C3f(5.f)));
  const RayScene rays(s);
  SurfelOptions o;
  o.sampler = GetParam();
  o.spacing = 0.02f;  // ~40k surfels
  o.light_samples = 4;
  o.batch_surfels = 1024;
  auto want = sample_surfels(s, o);
  shade_direct(rays, o, want);
  std::vector<Surfel> got;
  size_t largest = 0;
  const SurfelGenerationStats st = generate_surfels(s, rays, o, [&](std::span<const Surfel> b) {
    largest = std::max(largest, b.size());
    got.insert(got.end(), b.begin(), b.end());
  });
  EXPECT_LE(largest, o.batch_surfels);
  EXPECT_GT(st.batches, 10u);
  EXPECT_EQ(st.surfels, want.size());
  ASSERT_EQ(got.size(), want.size());
  for (size_t i = 0; i < got.size(); ++i) {
    ASSERT_EQ(got[i].position, want[i].position) << i;
    ASSERT_EQ(got[i].radius, want[i].radius) << i;
    ASSERT_EQ(got[i].radiance, want[i].radiance) << i;
  }
}

INSTANTIATE_TEST_SUITE_P(Samplers, GenerateSurfels,
                         ::testing::Values(SurfelSampler::kUniform, SurfelSampler::kPoisson));

}  // namespace
}  // namespace pbgi
