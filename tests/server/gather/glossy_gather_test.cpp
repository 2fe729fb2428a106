// Glossy receivers (docs/gather.md, "Glossy receivers"): the GGX lobe's
// convolution against closed forms (a uniform sphere reflects L times the
// lobe's directional albedo, integrated here from brdf.h without its
// sampler), what a near mirror shows, the adaptive microbuffer against the
// fixed one at an equal node budget, the diffuse path left untouched, and
// input errors.
#include "common/errors.h"
#include "server/gather/gather.h"
#include "server/scene/brdf.h"
#include "surfel_shapes.h"
#include "surfel_tree.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

namespace pbgi {
namespace {

using Imath::C3f;
using Imath::V3f;
constexpr float kPi = 3.14159265358979f;

// Integral of f_spec cos dwi over the directions wi where `seen(wi)`, by a
// midpoint rule over half vectors (dwi = 4 (wo.h) dwh), denser near the
// normal (theta_h = pi/2 x^3) so that a roughness-0.05 lobe is resolved.
template <class Seen>
C3f ggx_integral(const V3f& n, const V3f& wo, float roughness, const C3f& f0, const Seen& seen) {
  BrdfLobes lobes;
  lobes.f0 = f0;
  lobes.alpha = std::max(kMinGgxAlpha, roughness * roughness);
  lobes.specular = true;
  const Brdf brdf(lobes, n);
  V3f t = std::abs(n.x) < 0.9f ? V3f(1, 0, 0) : V3f(0, 1, 0);
  t = (t - n * n.dot(t)).normalized();
  const V3f b = n.cross(t);
  constexpr int kTheta = 1500, kPhi = 360;
  double r = 0, g = 0, bl = 0;
  for (int i = 0; i < kTheta; ++i) {
    const double x0 = double(i) / kTheta, x1 = double(i + 1) / kTheta, xm = 0.5 * (x0 + x1);
    const double th = 0.5 * M_PI * xm * xm * xm;
    const double dth = 0.5 * M_PI * (x1 * x1 * x1 - x0 * x0 * x0);
    for (int j = 0; j < kPhi; ++j) {
      const double ph = 2 * M_PI * (j + 0.5) / kPhi;
      const V3f h = float(std::sin(th) * std::cos(ph)) * t + float(std::sin(th) * std::sin(ph)) * b +
                    float(std::cos(th)) * n;
      const float oh = wo.dot(h);
      if (!(oh > 0.f)) continue;
      const V3f wi = 2.f * oh * h - wo;
      const float cos_i = wi.dot(n);
      if (!(cos_i > 0.f) || !seen(wi)) continue;
      const C3f f = brdf.eval(wo, wi);
      const double w = cos_i * 4.0 * oh * std::sin(th) * dth * (2 * M_PI / kPhi);
      r += f.x * w;
      g += f.y * w;
      bl += f.z * w;
    }
  }
  return C3f(float(r), float(g), float(bl));
}

// Directional albedo of the specular lobe.
C3f ggx_albedo(const V3f& n, const V3f& wo, float roughness, const C3f& f0) {
  return ggx_integral(n, wo, roughness, f0, [](const V3f&) { return true; });
}

// Sphere of radius R around the origin, seen from inside, emitting L.
std::vector<Surfel> inside_sphere(float radius, uint32_t count, const C3f& radiance) {
  std::vector<Surfel> s;
  test::add_sphere(s, V3f(0), radius, count, radiance);
  for (Surfel& x : s) x.normal = -x.normal;
  return s;
}

V3f view_at(float degrees) {
  const float a = degrees * kPi / 180.f;
  return V3f(std::sin(a), 0.f, std::cos(a));
}

Receiver glossy_receiver(const V3f& p, const V3f& n, const V3f& view, float roughness,
                         const C3f& f0) {
  Receiver r{p, n};
  r.glossy.view = view;
  r.glossy.roughness = roughness;
  r.glossy.specular = f0;
  return r;
}

TEST(GlossyGather, UniformSphereReflectsTheLobesAlbedo) {
  const C3f L(2.f, 1.f, 0.5f);
  test::SurfelTree tree(inside_sphere(3.f, 20000, L));
  Gatherer g(tree, GatherOptions{});
  const V3f n(0, 0, 1);
  float worst = 0.f;
  for (const float roughness : {0.05f, 0.1f, 0.3f, 0.6f, 1.f}) {
    for (const float angle : {0.f, 45.f, 75.f}) {
      const V3f v = view_at(angle);
      const C3f f0(0.9f, 0.5f, 0.04f);
      const GatherResult r = g.gather(glossy_receiver(V3f(0), n, v, roughness, f0));
      const C3f a = ggx_albedo(n, v, roughness, f0);
      for (int c = 0; c < 3; ++c) {
        const float expected = L[c] * a[c];
        EXPECT_NEAR(r.glossy[c], expected, 0.03f * expected)
            << "roughness " << roughness << " view " << angle << " deg, channel " << c;
        worst = std::max(worst, std::abs(r.glossy[c] / expected - 1.f));
      }
      // The diffuse result is that of a diffuse receiver.
      EXPECT_NEAR(r.irradiance.x, kPi * L.x, 0.01f * kPi * L.x);
    }
  }
  std::printf("uniform sphere: worst relative glossy error %.4f\n", worst);
}

// A floor receiver facing an emitting wall (radiance 1) at grazing to
// steep views: the lobe's convolution with the part of the sphere the wall
// covers, against a quadrature of brdf.h. At 60 degrees a roughness-0.05
// lobe passes above the wall: the fixed 8 x 8 buffer smears the wall's
// pixels into it (0.05 measured), the adaptive one does not.
TEST(GlossyGather, FloorReceiverFacingAWallMatchesTheQuadrature) {
  constexpr float kX = 1.5f, kY = 2.f, kZ = 2.f;  // wall x = kX, |y| < kY, 0 < z < kZ
  std::vector<Surfel> s;
  test::add_quad(s, V3f(kX, -kY, 0), V3f(0, 2 * kY, 0), V3f(0, 0, kZ), 160, 80, C3f(1));
  for (Surfel& x : s) x.normal = V3f(-1, 0, 0);
  test::SurfelTree tree(s);
  auto on_wall = [&](const V3f& w) {
    if (!(w.x > 0.f)) return false;
    const float t = kX / w.x;
    return std::abs(t * w.y) < kY && t * w.z > 0.f && t * w.z < kZ;
  };
  Gatherer g(tree, GatherOptions{});
  const V3f n(0, 0, 1);
  for (const float elevation : {15.f, 45.f, 60.f}) {
    for (const float roughness : {0.05f, 0.4f}) {
      const float e = elevation * kPi / 180.f;
      const V3f mirror(std::cos(e), 0.f, std::sin(e));
      const V3f v = (2.f * n.dot(mirror) * n - mirror).normalized();
      const float expected = ggx_integral(n, v, roughness, C3f(0.9f), on_wall).x;
      const float got =
          g.gather(glossy_receiver(V3f(0, 0, 0.001f), n, v, roughness, C3f(0.9f))).glossy.x;
      EXPECT_NEAR(got, expected, std::max(0.03f * expected, 0.005f))
          << "elevation " << elevation << ", roughness " << roughness;
    }
  }
}

// A near mirror (roughness 0.05) tilted towards a red wall, with a green
// wall on the viewer's side: it reflects red. A diffuse receiver at the
// same place sees both walls alike.
TEST(GlossyGather, NearMirrorReflectsTheWallItFacesNotTheOneBehindTheViewer) {
  std::vector<Surfel> s;
  // Red wall around direction (1, 0, -1)/sqrt 2, at distance ~2.8; green
  // around (1, 0, 1)/sqrt 2 (where the viewer is).
  const V3f red_c(2, 0, -2), green_c(2, 0, 2);
  const V3f red_n = V3f(-1, 0, 1).normalized(), green_n = V3f(-1, 0, -1).normalized();
  auto wall = [&](const V3f& c, const V3f& normal, const C3f& col) {
    const V3f u(0, 3, 0), v = normal.cross(u).normalized() * 3.f;
    test::add_quad(s, c - 0.5f * u - 0.5f * v, u, v, 60, 60, col);
  };
  wall(red_c, red_n, C3f(1, 0, 0));
  wall(green_c, green_n, C3f(0, 1, 0));
  test::SurfelTree tree(s);
  Gatherer g(tree, GatherOptions{});
  const V3f n(1, 0, 0), v = V3f(1, 0, 1).normalized();
  const GatherResult r = g.gather(glossy_receiver(V3f(0), n, v, 0.05f, C3f(1)));
  EXPECT_GT(r.glossy.x, 0.5f);                // most of the lobe sees red (L = 1)
  EXPECT_LT(r.glossy.y, 0.02f * r.glossy.x);  // and next to nothing green
  EXPECT_NEAR(r.irradiance.x, r.irradiance.y, 0.05f * r.irradiance.x);
}

// A small, very bright patch (radiance 300, 0.1 m) on a dim wall (0.1),
// in the tail of a roughness-0.3 lobe, at six places. The wide lobe is
// evaluated per pixel (binned from its 256 samples, the patch's pixels
// held zero or one sample: 41% rms error when this test was written);
// refinement by the lobe alone leaves the patch's coarse pixel unrefined,
// so the lobe's mean over the whole pixel weighs it; refinement by lobe x
// incoming radiance resolves it in fine pixels. Against a quadrature of
// brdf.h over the wall and the patch (measured: 7.5% rms by the lobe
// alone, 5.8% with radiance weight 0.5, 5.2% with 1).
TEST(GlossyGather, RadianceDrivenRefinementResolvesABrightSourceInTheLobesTail) {
  constexpr float kX = 1.5f, kY = 2.f, kZ = 2.f, kDim = 0.1f, kBright = 300.f, kHalf = 0.05f;
  const V3f n(0, 0, 1);
  const float e = 30.f * kPi / 180.f;
  const V3f mirror(std::cos(e), 0.f, std::sin(e));
  const V3f v = (2.f * n.dot(mirror) * n - mirror).normalized();
  const float hit_z = kX * std::tan(e);
  double err[3] = {0, 0, 0};
  uint64_t nodes[3] = {0, 0, 0};
  int cases = 0;
  for (const float dz : {0.35f, 0.5f, 0.7f}) {
    for (const float dy : {0.f, 0.3f}) {
      const V3f patch_c(kX - 0.01f, dy, hit_z + dz);
      std::vector<Surfel> s;
      test::add_quad(s, V3f(kX, -kY, 0), V3f(0, 2 * kY, 0), V3f(0, 0, kZ), 160, 80, C3f(kDim));
      const size_t wall = s.size();
      test::add_quad(s, patch_c - V3f(0, kHalf, kHalf), V3f(0, 2 * kHalf, 0), V3f(0, 0, 2 * kHalf), 6, 6,
                     C3f(kBright));
      for (Surfel& x : s) x.normal = V3f(-1, 0, 0);
      (void)wall;
      test::SurfelTree tree(s);
      auto on_patch = [&](const V3f& w) {
        if (!(w.x > 0.f)) return false;
        const float t = patch_c.x / w.x;
        return std::abs(t * w.y - patch_c.y) < kHalf && std::abs(t * w.z - patch_c.z) < kHalf;
      };
      auto on_wall = [&](const V3f& w) {
        if (!(w.x > 0.f) || on_patch(w)) return false;
        const float t = kX / w.x;
        return std::abs(t * w.y) < kY && t * w.z > 0.f && t * w.z < kZ;
      };
      const float truth = kDim * ggx_integral(n, v, 0.3f, C3f(1), on_wall).x +
                          kBright * ggx_integral(n, v, 0.3f, C3f(1), on_patch).x;
      const float weights[3] = {0.f, 0.5f, 1.f};
      for (int b = 0; b < 3; ++b) {
        GatherOptions o;
        o.glossy_radiance_weight = weights[b];
        Gatherer g(tree, o);
        const float got = g.gather(glossy_receiver(V3f(0, 0, 0.001f), n, v, 0.3f, C3f(1))).glossy.x;
        err[b] += std::pow(double(got / truth - 1.f), 2);
        nodes[b] += g.counters().nodes_visited + g.counters().glossy_nodes_visited;
      }
      ++cases;
    }
  }
  for (double& x : err) x = std::sqrt(x / cases);
  std::printf("bright patch in a roughness-0.3 lobe's tail: rel rms error, radiance weight 0: %.4f (%llu nodes), "
              "0.5: %.4f (%llu nodes), 1: %.4f (%llu nodes)\n",
              err[0], (unsigned long long)nodes[0], err[1], (unsigned long long)nodes[1], err[2],
              (unsigned long long)nodes[2]);
  EXPECT_LT(err[0], 0.12);
  EXPECT_LT(err[1], 0.85 * err[0]);
  EXPECT_LT(err[2], 0.85 * err[0]);
  // At about the same cost.
  EXPECT_LT(nodes[1], uint64_t(1.1 * double(nodes[0])));
}

// Receivers on a floor below a checkered emitting wall, each with a
// roughness-0.1 lobe aimed at the wall; the reference is the adaptive
// buffer at its finest (64 per face side, every cell holding 0.1% of the
// lobe split) with a fine cut.
struct Checker {
  std::vector<Surfel> surfels;
  std::vector<Receiver> receivers;
};

Checker checker_scene() {
  Checker c;
  // Wall x = 2, facing -x, 4 x 4 m, checker of 0.25 m squares.
  const int kCells = 16;
  for (int a = 0; a < kCells; ++a) {
    for (int b = 0; b < kCells; ++b) {
      const C3f col = ((a + b) % 2) ? C3f(4.f) : C3f(0.2f);
      const float cell = 4.f / kCells;
      test::add_quad(c.surfels, V3f(2.f, -2.f + a * cell, b * cell), V3f(0, cell, 0),
                     V3f(0, 0, cell), 8, 8, col, /*flip=*/false);
    }
  }
  for (Surfel& s : c.surfels) s.normal = V3f(-1, 0, 0);
  for (int i = 0; i < 8; ++i) {
    const V3f p(-0.5f + 0.17f * i, -0.6f + 0.15f * i, 0.f);
    // Aim the mirror direction at a point of the wall.
    const V3f target(2.f, -1.f + 0.27f * i, 0.6f + 0.2f * i);
    const V3f r = (target - p).normalized();
    const V3f n(0, 0, 1);
    const V3f view = (2.f * n.dot(r) * n - r).normalized();
    c.receivers.push_back(glossy_receiver(p, n, view, 0.1f, C3f(1)));
  }
  return c;
}

struct GlossyRun {
  std::vector<C3f> glossy;
  uint64_t nodes = 0;
};

GlossyRun run(const test::SurfelTree& tree, const std::vector<Receiver>& rs, const GatherOptions& o) {
  Gatherer g(tree, o);
  std::vector<GatherResult> out(rs.size());
  g.gather_tile(rs, out);
  GlossyRun r;
  for (const GatherResult& x : out) r.glossy.push_back(x.glossy);
  r.nodes = g.counters().nodes_visited + g.counters().glossy_nodes_visited;
  return r;
}

double rel_rms(const GlossyRun& a, const GlossyRun& ref) {
  double e = 0, n = 0;
  for (size_t i = 0; i < a.glossy.size(); ++i) {
    const double d = a.glossy[i].x - ref.glossy[i].x;
    e += d * d;
    n += double(ref.glossy[i].x) * ref.glossy[i].x;
  }
  return std::sqrt(e / n);
}

TEST(GlossyGather, AdaptiveBeatsTheFixedBufferAtEqualNodeBudget) {
  const Checker scene = checker_scene();
  test::SurfelTree tree(scene.surfels);
  GatherOptions ref_o;
  ref_o.glossy_max_resolution = 64;
  ref_o.glossy_importance = 1e-3f;
  ref_o.max_solid_angle = 0.002f;
  const GlossyRun ref = run(tree, scene.receivers, ref_o);

  GatherOptions adaptive_o;  // defaults: 32, 0.01
  const GlossyRun adaptive = run(tree, scene.receivers, adaptive_o);

  // The fixed 8 x 8 buffer, with the cut refined until it visits at least
  // as many nodes as the adaptive gather.
  GatherOptions fixed_o;
  fixed_o.glossy_max_resolution = fixed_o.microbuffer_resolution;
  GlossyRun fixed = run(tree, scene.receivers, fixed_o);
  while (fixed.nodes < adaptive.nodes && fixed_o.max_solid_angle > 1e-4f) {
    fixed_o.max_solid_angle *= 0.7f;
    fixed = run(tree, scene.receivers, fixed_o);
  }
  ASSERT_GE(fixed.nodes, adaptive.nodes);
  const double e_adaptive = rel_rms(adaptive, ref), e_fixed = rel_rms(fixed, ref);
  std::printf("glossy roughness 0.1: rel rms adaptive %.4f (%llu nodes), fixed 8x8 %.4f (%llu nodes, "
              "max_solid_angle %.4f)\n",
              e_adaptive, (unsigned long long)adaptive.nodes, e_fixed,
              (unsigned long long)fixed.nodes, fixed_o.max_solid_angle);
  EXPECT_LT(e_adaptive, 0.5 * e_fixed);
}

// Diffuse receivers give the same bits whatever the glossy options and
// whether glossy receivers share their batch; a glossy receiver's
// irradiance and AO are those of the same receiver without its lobe.
TEST(GlossyGather, DiffuseResultsAreBitIdentical) {
  const std::vector<Surfel> s = test::box_room(4.f, 20000);
  test::SurfelTree tree(s);
  std::vector<Receiver> diffuse, mixed;
  for (int i = 0; i < 40; ++i) {
    const V3f p(0.3f + 0.09f * i, 0.5f + 0.07f * i, 0.01f);
    diffuse.push_back({p, V3f(0, 0, 1)});
    mixed.push_back(i % 3 ? diffuse.back()
                          : glossy_receiver(p, V3f(0, 0, 1), view_at(30.f), 0.2f, C3f(0.5f)));
  }
  for (const GatherMethod method : {GatherMethod::kPbgi, GatherMethod::kFpbgi}) {
    GatherOptions a, b;
    a.method = b.method = method;
    b.glossy_max_resolution = 64;
    b.glossy_importance = 0.001f;
    std::vector<GatherResult> ra(diffuse.size()), rb(mixed.size());
    Gatherer(tree, a).gather_tile(diffuse, ra);
    Gatherer(tree, b).gather_tile(mixed, rb);
    for (size_t i = 0; i < diffuse.size(); ++i) {
      EXPECT_EQ(ra[i].irradiance.x, rb[i].irradiance.x) << i;
      EXPECT_EQ(ra[i].irradiance.y, rb[i].irradiance.y) << i;
      EXPECT_EQ(ra[i].irradiance.z, rb[i].irradiance.z) << i;
      EXPECT_EQ(ra[i].ao, rb[i].ao) << i;
      EXPECT_EQ(ra[i].glossy, C3f(0)) << i;
      if (mixed[i].glossy.active()) {
        EXPECT_GT(rb[i].glossy.x, 0.f) << i;
      } else {
        EXPECT_EQ(rb[i].glossy, C3f(0)) << i;
      }
    }
  }
}

// The factorized gather convolves a glossy member's lobe with its own
// microbuffer composited with the cluster's shared far content, and gathers
// the refined pixels per member: within a few % of PBGI (the far content is
// seen from the cluster's active receiver), and exactly PBGI's when every
// node is near (receivers spread over metres).
TEST(GlossyGather, FactorizedGlossyFollowsPbgi) {
  const std::vector<Surfel> s = test::box_room(4.f, 20000);
  test::SurfelTree tree(s);
  auto run_both = [&](const std::vector<Receiver>& rs, std::vector<GatherResult>& rp,
                      std::vector<GatherResult>& rf, GatherCounters& fc) {
    GatherOptions p, f;
    f.method = GatherMethod::kFpbgi;
    rp.resize(rs.size());
    rf.resize(rs.size());
    Gatherer(tree, p).gather_tile(rs, rp);
    Gatherer gf(tree, f);
    gf.gather_tile(rs, rf);
    fc = gf.counters();
  };
  std::vector<Receiver> spread, compact;
  for (int i = 0; i < 16; ++i) {
    spread.push_back(glossy_receiver(V3f(0.5f + 0.2f * i, 1.f, 0.01f), V3f(0, 0, 1),
                                     view_at(10.f + 4.f * i), 0.1f, C3f(1)));
    compact.push_back(glossy_receiver(V3f(2.f + 0.01f * (i % 4), 1.5f + 0.01f * (i / 4), 0.01f),
                                      V3f(0, 0, 1), view_at(30.f + i), 0.3f, C3f(1)));
  }
  std::vector<GatherResult> rp, rf;
  GatherCounters fc;
  run_both(spread, rp, rf, fc);
  EXPECT_EQ(fc.glossy_receivers, spread.size());
  for (size_t i = 0; i < spread.size(); ++i) EXPECT_EQ(rp[i].glossy, rf[i].glossy) << i;
  run_both(compact, rp, rf, fc);
  EXPECT_EQ(fc.glossy_receivers, compact.size());
  for (size_t i = 0; i < compact.size(); ++i) {
    EXPECT_GT(rf[i].glossy.x, 0.f) << i;
    EXPECT_NEAR(rf[i].glossy.x, rp[i].glossy.x, 0.03f * rp[i].glossy.x) << i;
  }
}

TEST(GlossyGather, BadLobesAreErrorsNamingTheReceiver) {
  test::SurfelTree tree(inside_sphere(1.f, 2000, C3f(1)));
  Gatherer g(tree, GatherOptions{});
  std::vector<Receiver> rs(4, Receiver{V3f(0), V3f(0, 0, 1)});
  std::vector<GatherResult> out(rs.size());
  auto expect_error = [&](const std::vector<Receiver>& batch, const std::string& what) {
    try {
      g.gather_tile(batch, out);
      ADD_FAILURE() << "no error for " << what;
    } catch (const InvalidArgument& e) {
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  };
  std::vector<Receiver> bad = rs;
  bad[2] = glossy_receiver(V3f(0), V3f(0, 0, 1), V3f(0, 0, 2), 0.3f, C3f(1));
  expect_error(bad, "receiver 2.glossy.view");
  bad = rs;
  bad[3] = glossy_receiver(V3f(0), V3f(0, 0, 1), V3f(0, 0, 1), 1.5f, C3f(1));
  expect_error(bad, "receiver 3.glossy.roughness");
  bad = rs;
  bad[1] = glossy_receiver(V3f(0), V3f(0, 0, 1), V3f(0, 0, 1), 0.5f, C3f(1, -1, 0));
  expect_error(bad, "receiver 1.glossy.specular");
  // Inactive lobes (black specular) are not checked further: diffuse.
  bad = rs;
  bad[0] = glossy_receiver(V3f(0), V3f(0, 0, 7), V3f(0, 0, 1), 9.f, C3f(0));
  EXPECT_NO_THROW(g.gather_tile(bad, out));
  EXPECT_THROW(g.gather(glossy_receiver(V3f(0), V3f(0, 0, 1), V3f(0, 0, 0.5f), 0.3f, C3f(1))),
               InvalidArgument);
}

TEST(GlossyGather, OptionsAreValidated) {
  GatherOptions o;
  o.glossy_max_resolution = 65;
  EXPECT_THROW(o.validate(), InvalidArgument);
  o.glossy_max_resolution = 3;
  EXPECT_THROW(o.validate(), InvalidArgument);
  o = GatherOptions{};
  o.glossy_importance = 0.f;
  EXPECT_THROW(o.validate(), InvalidArgument);
  o.glossy_importance = 1.5f;
  EXPECT_THROW(o.validate(), InvalidArgument);
  o = GatherOptions{};
  o.glossy_radiance_weight = -0.1f;
  EXPECT_THROW(o.validate(), InvalidArgument);
  o.glossy_radiance_weight = std::nanf("");
  EXPECT_THROW(o.validate(), InvalidArgument);
  o = GatherOptions{};
  o.microbuffer_resolution = 12;
  EXPECT_EQ(o.effective_glossy_resolution(), 24u);
  o.microbuffer_resolution = 32;
  EXPECT_EQ(o.effective_glossy_resolution(), 32u);  // no refinement
  EXPECT_NO_THROW(o.validate());
}

}  // namespace
}  // namespace pbgi
