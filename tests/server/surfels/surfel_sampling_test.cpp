#include "common/errors.h"
#include "server/scene/rng.h"
#include "server/surfels/surfels.h"
#include "tests/server/scene/test_scenes.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numeric>

namespace pbgi {
namespace {

double triangle_area(const Scene& s, size_t i) {
  const TriangleSoup& t = s.triangles;
  const V3f& a = t.positions[t.indices[3 * i]];
  const V3f& b = t.positions[t.indices[3 * i + 1]];
  const V3f& c = t.positions[t.indices[3 * i + 2]];
  return 0.5 * (b - a).cross(c - a).length();
}

double total_area(const Scene& s) {
  double a = 0;
  for (size_t i = 0; i < s.triangles.triangle_count(); ++i) a += triangle_area(s, i);
  return a;
}

double surfel_area(const std::vector<Surfel>& v) {
  return std::accumulate(v.begin(), v.end(), 0.0,
                         [](double acc, const Surfel& s) { return acc + s.area(); });
}

// An open box (five walls of different sizes and orientations) plus a fan
// of thin and tiny triangles: a mix of large and sub-spacing triangles.
Scene mixed_scene() {
  Scene s;
  s.source_path = "mixed";
  const uint32_t white = test::add_material(s, {0.8f, 0.8f, 0.8f});
  const uint32_t red = test::add_material(s, {0.7f, 0.1f, 0.1f});
  const uint32_t lamp = test::add_material(s, {0.f, 0.f, 0.f}, {5.f, 5.f, 5.f});
  test::add_quad(s, V3f(0, 0, 0), V3f(4, 0, 0), V3f(4, 3, 0), V3f(0, 3, 0), white, "/floor");
  test::add_quad(s, V3f(0, 0, 0), V3f(0, 3, 0), V3f(0, 3, 2), V3f(0, 0, 2), red, "/left");
  test::add_quad(s, V3f(4, 0, 0), V3f(4, 0, 2), V3f(4, 3, 2), V3f(4, 3, 0), white, "/right");
  test::add_quad(s, V3f(0, 3, 0), V3f(4, 3, 0), V3f(4, 3, 2), V3f(0, 3, 2), white, "/back");
  test::add_square_z(s, 2, 1.5f, 1.99f, 0.25f, lamp, true, "/lamp");
  // A finely tessellated strip: 2000 triangles each far below the spacing.
  TriangleSoup& t = s.triangles;
  const uint32_t mesh = static_cast<uint32_t>(t.mesh_paths.size());
  t.mesh_paths.push_back("/fine");
  t.double_sided.push_back(0);
  for (int i = 0; i < 1000; ++i) {
    const uint32_t base = static_cast<uint32_t>(t.positions.size());
    const float x0 = 0.5f + i * 0.002f, x1 = x0 + 0.002f;
    t.positions.insert(t.positions.end(),
                       {V3f(x0, 0.5f, 0.01f), V3f(x1, 0.5f, 0.01f), V3f(x1, 0.6f, 0.01f),
                        V3f(x0, 0.6f, 0.01f)});
    t.indices.insert(t.indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
    t.material.insert(t.material.end(), {white, white});
    t.mesh.insert(t.mesh.end(), {mesh, mesh});
  }
  return s;
}

TEST(SampleSurfels, AreaIsConserved) {
  const Scene s = mixed_scene();
  SurfelOptions o;
  o.target_surfels = 5000;
  const auto surfels = sample_surfels(s, o);
  const double a = total_area(s);
  EXPECT_NEAR(surfel_area(surfels) / a, 1.0, 1e-3);
}

TEST(SampleSurfels, CountNearTarget) {
  const Scene s = mixed_scene();
  for (const uint64_t target : {1000ull, 20000ull}) {
    SurfelOptions o;
    o.target_surfels = target;
    const auto surfels = sample_surfels(s, o);
    EXPECT_NEAR(static_cast<double>(surfels.size()) / target, 1.0, 0.1) << target;
  }
}

TEST(SampleSurfels, ExplicitSpacingSetsDensity) {
  Scene s;
  const uint32_t m = test::add_material(s, {0.5f, 0.5f, 0.5f});
  test::add_square_z(s, 0, 0, 0, 5.f, m);  // area 100
  SurfelOptions o;
  o.spacing = 0.1f;                        // ~ 100 / 0.01 = 10000 surfels
  const auto surfels = sample_surfels(s, o);
  EXPECT_NEAR(surfels.size() / 10000.0, 1.0, 0.02);
  // Uniform density: every radius is the disk of a spacing^2 cell.
  for (const Surfel& x : surfels) EXPECT_NEAR(x.area(), 0.01f, 0.01f * 0.02f);
}

TEST(SampleSurfels, SurfelsLieOnTheirTrianglesPlanes) {
  const Scene s = mixed_scene();
  SurfelOptions o;
  o.target_surfels = 3000;
  const auto surfels = sample_surfels(s, o);
  // Every surfel lies in the plane of some triangle with the same normal,
  // inside that triangle.
  const TriangleSoup& t = s.triangles;
  for (const Surfel& x : surfels) {
    EXPECT_NEAR(x.normal.length(), 1.f, 1e-5f);
    bool found = false;
    for (size_t i = 0; i < t.triangle_count() && !found; ++i) {
      const V3f& a = t.positions[t.indices[3 * i]];
      const V3f& b = t.positions[t.indices[3 * i + 1]];
      const V3f& c = t.positions[t.indices[3 * i + 2]];
      const V3f n = (b - a).cross(c - a).normalized();
      if (n.dot(x.normal) < 0.9999f || std::fabs((x.position - a).dot(n)) > 1e-5f) continue;
      // Inside: the three sub-triangle orientations agree with n.
      const V3f p = x.position;
      found = (b - a).cross(p - a).dot(n) >= -1e-6f && (c - b).cross(p - b).dot(n) >= -1e-6f &&
              (a - c).cross(p - c).dot(n) >= -1e-6f;
    }
    EXPECT_TRUE(found) << x.position;
  }
}

TEST(SampleSurfels, MaterialsCarriedAndEmissionIsInitialRadiance) {
  const Scene s = mixed_scene();
  SurfelOptions o;
  o.target_surfels = 2000;
  size_t red = 0, lamp = 0;
  for (const Surfel& x : sample_surfels(s, o)) {
    if (x.albedo == C3f(0.7f, 0.1f, 0.1f)) {
      ++red;
      EXPECT_NEAR(x.position.x, 0.f, 1e-6f);
      EXPECT_NEAR(x.normal.x, 1.f, 1e-6f);  // the left wall faces +X
    }
    EXPECT_EQ(x.radiance, x.emission);
    if (x.emission.x > 0) ++lamp;
  }
  EXPECT_GT(red, 0u);
  EXPECT_GT(lamp, 0u);
}

TEST(SampleSurfels, DeterministicForASeed) {
  const Scene s = mixed_scene();
  SurfelOptions o;
  o.target_surfels = 4000;
  const auto a = sample_surfels(s, o);
  const auto b = sample_surfels(s, o);
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    ASSERT_EQ(a[i].position, b[i].position) << i;
    ASSERT_EQ(a[i].radius, b[i].radius) << i;
  }
  o.seed = 2;
  const auto c = sample_surfels(s, o);
  EXPECT_TRUE(c.size() != a.size() || c[0].position != a[0].position);
}

TEST(SampleSurfels, EvenlyCoversALargeTriangle) {
  // One triangle, 1000 surfels: the low-discrepancy placement leaves no
  // clumps, unlike independent uniform points (whose nearest-neighbour
  // distance has a heavy short tail).
  Scene s;
  const uint32_t m = test::add_material(s, {0.5f, 0.5f, 0.5f});
  TriangleSoup& t = s.triangles;
  t.positions = {V3f(0, 0, 0), V3f(10, 0, 0), V3f(0, 10, 0)};
  t.indices = {0, 1, 2};
  t.material = {m};
  SurfelOptions o;
  o.target_surfels = 1000;
  const auto surfels = sample_surfels(s, o);
  ASSERT_NEAR(surfels.size(), 1000.0, 1.0);
  const float spacing = std::sqrt(50.f / surfels.size());
  float min_nn = 1e30f;
  for (size_t i = 0; i < surfels.size(); ++i) {
    for (size_t j = 0; j < surfels.size(); ++j) {
      if (i != j) min_nn = std::min(min_nn, (surfels[i].position - surfels[j].position).length());
    }
  }
  EXPECT_GT(min_nn, 0.2f * spacing);
}

TEST(SampleSurfels, SkipsDegenerateTriangles) {
  Scene s;
  const uint32_t m = test::add_material(s, {0.5f, 0.5f, 0.5f});
  test::add_square_z(s, 0, 0, 0, 1.f, m);
  TriangleSoup& t = s.triangles;
  const uint32_t base = static_cast<uint32_t>(t.positions.size());
  t.positions.insert(t.positions.end(), {V3f(0, 0, 0), V3f(1, 1, 1), V3f(2, 2, 2),  // collinear
                                         V3f(NAN, 0, 0), V3f(0, 1, 0), V3f(1, 0, 0)});
  t.indices.insert(t.indices.end(), {base, base + 1, base + 2, base + 3, base + 4, base + 5});
  t.material.insert(t.material.end(), {m, m});
  t.mesh.insert(t.mesh.end(), {0, 0});
  SurfelOptions o;
  o.target_surfels = 400;
  const auto surfels = sample_surfels(s, o);
  EXPECT_NEAR(surfel_area(surfels), 4.0, 4e-3);
  for (const Surfel& x : surfels) {
    EXPECT_TRUE(std::isfinite(x.position.x) && std::isfinite(x.radius));
    EXPECT_NEAR(x.position.z, 0.f, 1e-6f);
  }
}

TEST(SampleSurfels, TinyMeshStillGetsASurfel) {
  Scene s;
  const uint32_t m = test::add_material(s, {0.5f, 0.5f, 0.5f});
  test::add_square_z(s, 0, 0, 0, 10.f, m, false, "/big");
  test::add_square_z(s, 0, 0, 1, 0.01f, m, false, "/speck");  // area 4e-4, spacing ~0.63
  SurfelOptions o;
  o.target_surfels = 1000;
  const auto surfels = sample_surfels(s, o);
  size_t speck = 0;
  for (const Surfel& x : surfels) {
    if (x.position.z == 1.f) {
      ++speck;
      EXPECT_NEAR(x.area(), 4e-4f, 1e-6f);
    }
  }
  EXPECT_EQ(speck, 1u);
  EXPECT_NEAR(surfel_area(surfels) / total_area(s), 1.0, 1e-4);
}

TEST(SampleSurfels, DoubleSidedMeshesGetTwins) {
  Scene s;
  const uint32_t m = test::add_material(s, {0.5f, 0.5f, 0.5f});
  test::add_quad(s, V3f(0, 0, 0), V3f(1, 0, 0), V3f(1, 1, 0), V3f(0, 1, 0), m, "/sheet", true);
  SurfelOptions o;
  o.target_surfels = 200;
  const auto surfels = sample_surfels(s, o);
  EXPECT_NEAR(surfels.size(), 200.0, 20.0);
  size_t up = 0, down = 0;
  for (const Surfel& x : surfels) (x.normal.z > 0 ? up : down)++;
  EXPECT_EQ(up, down);
  EXPECT_NEAR(surfel_area(surfels), 2.0, 2e-3);  // one per face
}

// Coincident coplanar copies are one surface: a surfel covered by k copies
// stands for 1/k of its share, so a doubled quad has the area of one (before:
// twice). The reversed copy (the other face of a thin wall) counts on its own.
TEST(SampleSurfels, CoincidentCoplanarCopiesCountTheirAreaOnce) {
  Scene s;
  const uint32_t m = test::add_material(s, {0.5f, 0.5f, 0.5f});
  test::add_quad(s, V3f(0, 0, 0), V3f(4, 0, 0), V3f(4, 4, 0), V3f(0, 4, 0), m, "/a");
  // The same square split along the other diagonal, and a partial copy.
  test::add_quad(s, V3f(4, 0, 0), V3f(4, 4, 0), V3f(0, 4, 0), V3f(0, 0, 0), m, "/b");
  test::add_quad(s, V3f(1, 0.5f, 0), V3f(2.5f, 0.5f, 0), V3f(2.5f, 3.5f, 0), V3f(1, 3.5f, 0), m, "/part");
  test::add_quad(s, V3f(0, 0, 0), V3f(0, 4, 0), V3f(4, 4, 0), V3f(4, 0, 0), m, "/back");  // faces -z
  SurfelOptions o;
  o.spacing = 0.05f;
  const std::vector<Surfel> surfels = sample_surfels(s, o);
  double up = 0, down = 0, part = 0;
  for (const Surfel& x : surfels) {
    (x.normal.z > 0 ? up : down) += x.area();
    const V3f& p = x.position;
    if (x.normal.z > 0 && p.x > 1.2f && p.x < 2.3f && p.y > 0.7f && p.y < 3.3f) part += x.area();
  }
  std::printf("uniform sampler, coincident copies: up %.4f (one copy 16), down %.4f\n", up, down);
  EXPECT_NEAR(up, 16.0, 0.01 * 16.0);
  EXPECT_NEAR(down, 16.0, 1e-3);
  // Where three copies overlap, the area per unit area is still 1.
  EXPECT_NEAR(part / (1.1 * 2.6), 1.0, 0.03);
}

TEST(SampleSurfels, EmptySceneAndBadOptions) {
  EXPECT_TRUE(sample_surfels(Scene(), SurfelOptions()).empty());
  SurfelOptions o;
  o.spacing = -1.f;
  EXPECT_THROW(o.validate(), InvalidArgument);
  o = SurfelOptions();
  o.target_surfels = 0;
  EXPECT_THROW(sample_surfels(mixed_scene(), o), InvalidArgument);
  o = SurfelOptions();
  o.light_samples = 0;
  EXPECT_THROW(o.validate(), InvalidArgument);
  o = SurfelOptions();
  o.spacing = 1e-6f;  // 1e13 surfels
  EXPECT_THROW(sample_surfels(mixed_scene(), o), InvalidArgument);
}

TEST(SampleSurfels, ReportsProgress) {
  const Scene s = mixed_scene();
  std::vector<float> seen;
  SurfelOptions o;
  o.target_surfels = 1000;
  sample_surfels(s, o, [&](const char* stage, float f) {
    EXPECT_STREQ(stage, "sample_surfels");
    seen.push_back(f);
  });
  ASSERT_GE(seen.size(), 2u);
  EXPECT_EQ(seen.front(), 0.f);
  EXPECT_EQ(seen.back(), 1.f);
  EXPECT_TRUE(std::is_sorted(seen.begin(), seen.end()));
}

}  // namespace
}  // namespace pbgi
