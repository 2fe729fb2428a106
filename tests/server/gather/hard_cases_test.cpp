// Hard cases for any PBGI gather, each with an error bound against a
// closed form or a fine reference gather (both PBGI and factorized):
// receivers lying on surfels, grazing receivers near a wall, coincident
// coplanar surfaces, a tiny very bright emitter (HDR-aware cut), light
// leaking through a thin wall, and a scene translated by 1e5.
#include "server/gather/gather.h"
#include "surfel_shapes.h"
#include "surfel_tree.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <vector>

namespace pbgi {
namespace {

using Imath::C3f;
using Imath::V3d;
using Imath::V3f;
constexpr float kPi = 3.14159265358979f;

// Irradiance at the origin with unit normal n from a uniformly emitting
// convex polygon of radiance L (vertices relative to the receiver), clipped
// to the hemisphere of n: Lambert's formula E = L/2 |sum_e theta_e n . u_e|,
// theta_e the angle an edge subtends and u_e the unit normal of its great
// circle.
double polygon_irradiance(std::vector<V3d> poly, const V3d& n, double L) {
  // Clip to n . x >= 0 (Sutherland-Hodgman).
  std::vector<V3d> clipped;
  for (size_t i = 0; i < poly.size(); ++i) {
    const V3d& a = poly[i];
    const V3d& b = poly[(i + 1) % poly.size()];
    const double da = n.dot(a), db = n.dot(b);
    if (da >= 0) clipped.push_back(a);
    if ((da >= 0) != (db >= 0)) clipped.push_back(a + (b - a) * (da / (da - db)));
  }
  double sum = 0;
  for (size_t i = 0; i < clipped.size(); ++i) {
    const V3d a = clipped[i].normalized();
    const V3d b = clipped[(i + 1) % clipped.size()].normalized();
    const V3d c = a.cross(b);
    const double len = c.length();
    if (len < 1e-15) continue;
    sum += std::atan2(len, a.dot(b)) * n.dot(c / len);
  }
  return 0.5 * L * std::abs(sum);
}

GatherOptions pbgi_options() { return GatherOptions{}; }
GatherOptions fpbgi_options() {
  GatherOptions o;
  o.method = GatherMethod::kFpbgi;
  return o;
}

std::vector<GatherResult> gather_all(const tree::TreeSource& tree, const GatherOptions& o,
                                     const std::vector<Receiver>& rs) {
  Gatherer g(tree, o);
  std::vector<GatherResult> out(rs.size());
  g.gather_tile(rs, out);
  return out;
}

TEST(HardCases, ReceiversLyingOnSurfelsSeeNoSelfShadow) {
  // Receivers exactly at surfel centers of a (black) floor, and between
  // them, under an emitting square: the floor must hide nothing.
  std::vector<Surfel> s;
  test::add_quad(s, {-2, -2, 0}, {4, 0, 0}, {0, 4, 0}, 100, 100, C3f(0));  // 4 cm surfels
  const float L = 2.f;
  test::add_quad(s, {-1, -1, 1}, {0, 2, 0}, {2, 0, 0}, 60, 60, C3f(L));  // faces -z
  // Floor surfels near the middle: receivers exactly at their centers, and
  // offset between them.
  std::vector<Receiver> rs;
  for (const Surfel& f : s) {
    if (f.normal.z > 0.f && std::abs(f.position.x - 0.1f) < 0.1f && std::abs(f.position.y) < 0.1f) {
      rs.push_back({f.position, f.normal});
      rs.push_back({f.position + V3f(0.013f, 0.007f, 0.f), f.normal});
    }
  }
  ASSERT_GT(rs.size(), 20u);
  test::SurfelTree tree(std::move(s));
  for (const GatherOptions& o : {pbgi_options(), fpbgi_options()}) {
    const std::vector<GatherResult> out = gather_all(tree, o, rs);
    double worst = 0;
    for (size_t i = 0; i < rs.size(); ++i) {
      const V3d p(rs[i].position);
      const double expect = polygon_irradiance(
          {V3d(-1, -1, 1) - p, V3d(1, -1, 1) - p, V3d(1, 1, 1) - p, V3d(-1, 1, 1) - p},
          V3d(0, 0, 1), L);
      worst = std::max(worst, std::abs(out[i].irradiance.x / expect - 1.0));
      EXPECT_NEAR(out[i].irradiance.x, expect, 0.02 * expect) << i;
      EXPECT_NEAR(out[i].ao, 1.0 - expect / (kPi * L), 0.02) << i;
    }
    std::printf("receivers on surfels (%s): worst error %.4f\n",
                o.method == GatherMethod::kPbgi ? "pbgi" : "fpbgi", worst);
  }
}

// Measured: mean |error| 0.005 (PBGI) / 0.008 (FPBGI); before near surfels
// carried their depth extent and ray-casts their pixel coverage, 0.034.
TEST(HardCases, GrazingReceiversNearAWall) {
  // An emitting wall x = a (10 x 5) standing on a black floor z = 0, seen
  // from receivers on the floor at distances a from 1 cm to 1 m, with
  // normals tilted towards and away from the wall: the wall meets the
  // receiver's horizon.
  const float L = 1.f;
  std::vector<Surfel> s;
  test::add_quad(s, {-3, -5, 0}, {3.f, 0, 0}, {0, 10, 0}, 150, 500, C3f(0));  // floor x < 0
  test::add_quad(s, {0, -5, 0}, {0, 0, 5}, {0, 10, 0}, 250, 500, C3f(L));     // wall x = 0, -x
  test::SurfelTree tree(std::move(s));
  std::vector<Receiver> rs;
  std::vector<double> expect;
  for (const float a : {0.01f, 0.05f, 0.2f, 1.f}) {
    for (const float tilt_deg : {-60.f, -20.f, 0.f, 20.f, 60.f}) {
      const float t = tilt_deg * kPi / 180.f;
      const V3f n(std::sin(t), 0.f, std::cos(t));  // t > 0 tilts towards the wall
      const V3f p(-a, 0.1f, 1e-3f);
      rs.push_back({p, n});
      const V3d q(p);
      expect.push_back(polygon_irradiance({V3d(0, -5, 0) - q, V3d(0, 5, 0) - q,
                                           V3d(0, 5, 5) - q, V3d(0, -5, 5) - q},
                                          V3d(n), L));
    }
  }
  for (const GatherOptions& o : {pbgi_options(), fpbgi_options()}) {
    const std::vector<GatherResult> out = gather_all(tree, o, rs);
    double sum = 0;
    for (size_t i = 0; i < rs.size(); ++i) {
      const double err = out[i].irradiance.x / expect[i] - 1.0;
      sum += std::abs(err);
      EXPECT_NEAR(out[i].irradiance.x, expect[i], 0.06 * expect[i])
          << "receiver " << i << " at x = " << rs[i].position.x << " normal " << rs[i].normal;
    }
    std::printf("grazing (%s): mean |error| %.4f\n",
                o.method == GatherMethod::kPbgi ? "pbgi" : "fpbgi", sum / double(rs.size()));
    EXPECT_LT(sum / double(rs.size()), 0.015);
  }
}

// Coincident coplanar surfaces (a duplicated mesh) are not the gather's to
// resolve: given two layers of surfels in one place it cannot tell a
// modelling error from real geometry, and summing them is right for the
// tree it is given. The contract is upstream: the surfel samplers never let
// coincident coplanar copies add up (server/surfels/coincident_surfaces.h),
// so the gather never sees doubled area. The case is tested there, through
// both samplers and this gather:
// tests/server/surfels/coincident_surfaces_gather_test.cpp
// (CoincidentSurfaces.DuplicatedEmitterLightsAsOneThroughSamplerAndGather),
// and at pipeline level by Stability.CoplanarDuplicateFloor. (This file's
// test target does not link the sampler, hence the other home.)

// Measured: mean |error| 0.0049 without, 0.0016 with the HDR cut (worst
// 0.0044), both methods.
TEST(HardCases, TinyBrightEmitterIsResolvedWithTheHdrCut) {
  // A 2 cm sphere of radiance 2e4 above a dim floor and wall: it brings
  // ~99% of the light. Unrefined it is drawn from the SH of a few nodes;
  // the HDR-aware cut refines the nodes holding it into pieces drawn with
  // their exact mean normals.
  const float R = 0.02f, H = 0.6f, Le = 2e4f;
  std::vector<Surfel> s;
  test::add_quad(s, {-2, -2, 0}, {4, 0, 0}, {0, 4, 0}, 120, 120, C3f(0.05f));
  test::add_quad(s, {-2, 2, 0}, {4, 0, 0}, {0, 0, 2}, 120, 60, C3f(0.05f));  // faces -y
  test::add_sphere(s, {0, 0, H}, R, 200, C3f(Le));
  test::SurfelTree tree(std::move(s));
  // Receivers on the floor, x from -0.6 to 0.6; the exact sphere term plus
  // the dim surfaces from a fine reference.
  std::vector<Receiver> rs;
  for (int i = 0; i <= 24; ++i) rs.push_back({{-0.6f + 0.05f * float(i), -0.3f, 1e-3f}, {0, 0, 1}});
  std::vector<double> sphere;
  for (const Receiver& r : rs) {
    const V3d d = V3d(0, 0, H) - V3d(r.position);
    const double sin2 = double(R) * R / d.length2();
    sphere.push_back(kPi * Le * sin2 * d.normalized().z);
  }
  GatherOptions plain;
  GatherOptions hdr;
  hdr.hdr_refine = 0.1f;
  for (const GatherMethod m : {GatherMethod::kPbgi, GatherMethod::kFpbgi}) {
    plain.method = hdr.method = m;
    const std::vector<GatherResult> a = gather_all(tree, plain, rs);
    const std::vector<GatherResult> b = gather_all(tree, hdr, rs);
    double err_plain = 0, err_hdr = 0, worst_hdr = 0;
    for (size_t i = 0; i < rs.size(); ++i) {
      // The dim surfaces bring < 1% here; the sphere is the reference.
      const double ea = std::abs(a[i].irradiance.x / sphere[i] - 1.0);
      const double eb = std::abs(b[i].irradiance.x / sphere[i] - 1.0);
      err_plain += ea / double(rs.size());
      err_hdr += eb / double(rs.size());
      worst_hdr = std::max(worst_hdr, eb);
    }
    std::printf("tiny bright emitter (%s): mean |error| %.4f without, %.4f with the HDR cut "
                "(worst %.4f)\n",
                m == GatherMethod::kPbgi ? "pbgi" : "fpbgi", err_plain, err_hdr, worst_hdr);
    EXPECT_LT(err_hdr, 0.03);
    EXPECT_LT(worst_hdr, 0.06);
    EXPECT_LE(err_hdr, err_plain + 1e-3);
  }
}

// Measured: worst inside irradiance 0.0047 (3e-5 of pi L outside; 11 when
// both faces of the wall were drawn from one SH), both methods.
TEST(HardCases, ThinWallsDoNotLeakLight) {
  // A closed dark room (inner faces black) whose walls are 2 cm thick,
  // their outer faces brightly lit (radiance 50): inside must stay dark.
  const float S = 2.f, t = 0.02f, Lout = 50.f;
  std::vector<Surfel> s;
  const auto box = [&](float lo, float hi, bool inward, const C3f& L, uint32_t n) {
    const float w = hi - lo;
    const V3f o(lo);
    // Six faces; add_quad's normal is u x v, flipped for outward faces.
    test::add_quad(s, o, {w, 0, 0}, {0, w, 0}, n, n, L, !inward);                  // z = lo
    test::add_quad(s, o + V3f(0, 0, w), {0, w, 0}, {w, 0, 0}, n, n, L, !inward);   // z = hi
    test::add_quad(s, o, {0, w, 0}, {0, 0, w}, n, n, L, !inward);                  // x = lo
    test::add_quad(s, o + V3f(w, 0, 0), {0, 0, w}, {0, w, 0}, n, n, L, !inward);   // x = hi
    test::add_quad(s, o, {0, 0, w}, {w, 0, 0}, n, n, L, !inward);                  // y = lo
    test::add_quad(s, o + V3f(0, w, 0), {w, 0, 0}, {0, 0, w}, n, n, L, !inward);   // y = hi
  };
  box(0.f, S, true, C3f(0.f), 60);           // the room, seen from inside
  box(-t, S + t, false, C3f(Lout), 61);      // its outside, facing out
  test::SurfelTree tree(std::move(s));
  std::vector<Receiver> rs;
  for (int i = 0; i < 8; ++i) {
    const float x = 0.01f + 0.28f * float(i);
    rs.push_back({{x, 0.5f, 1e-3f}, {0, 0, 1}});            // floor, near and far from walls
    rs.push_back({{1e-3f, x, 1.f}, {1, 0, 0}});             // on a wall
    rs.push_back({{x, 1.f, S - 1e-3f}, {0, 0, -1}});        // ceiling
  }
  for (const GatherOptions& o : {pbgi_options(), fpbgi_options()}) {
    const std::vector<GatherResult> out = gather_all(tree, o, rs);
    float worst = 0.f;
    for (size_t i = 0; i < rs.size(); ++i) {
      worst = std::max(worst, out[i].irradiance.x);
      // 0.1% of what the outside faces would send (pi L).
      EXPECT_LT(out[i].irradiance.x, 1e-3f * kPi * Lout) << "receiver " << i;
      EXPECT_LT(out[i].ao, 0.02f) << "receiver " << i;
    }
    std::printf("thin wall (%s): worst inside irradiance %.5f (pi L outside = %.1f)\n",
                o.method == GatherMethod::kPbgi ? "pbgi" : "fpbgi", worst, kPi * Lout);
  }
}

TEST(HardCases, CornellTranslatedBy1e5GivesTheSameResult) {
  // The same room at the origin and 1e5 away, both axes' receivers on a
  // 1/64 grid (exact at 1e5): the gather works relative to the receiver,
  // so only the rounding of the input positions (4 mm at 1e5) shows.
  const std::vector<Surfel> near = test::box_room(4.f, 30000);
  std::vector<Surfel> far = near;
  const V3f shift(1e5f, 1e5f, -1e5f);
  for (Surfel& x : far) x.position += shift;
  test::SurfelTree a(near), b(far);
  std::vector<Receiver> ra, rb;
  for (int j = 0; j < 12; ++j)
    for (int i = 0; i < 12; ++i) {
      const V3f p(0.5f + float(i) / 8.f, 2.5f + float(j) / 32.f, 1.f / 64.f);
      ra.push_back({p, {0, 0, 1}});
      rb.push_back({p + shift, {0, 0, 1}});
      const V3f w(1.f / 64.f, 0.5f + float(i) / 4.f, 0.5f + float(j) / 8.f);
      ra.push_back({w, {1, 0, 0}});
      rb.push_back({w + shift, {1, 0, 0}});
    }
  for (const GatherOptions& o : {pbgi_options(), fpbgi_options()}) {
    const std::vector<GatherResult> x = gather_all(a, o, ra), y = gather_all(b, o, rb);
    double se = 0, norm = 0, worst = 0;
    for (size_t i = 0; i < ra.size(); ++i) {
      const double d = (y[i].irradiance - x[i].irradiance).length();
      se += d * d;
      norm += x[i].irradiance.length();
      worst = std::max(worst, d / x[i].irradiance.length());
    }
    const double rms = std::sqrt(se / double(ra.size())) / (norm / double(ra.size()));
    std::printf("translated room (%s): rel rms %.5f, worst %.5f\n",
                o.method == GatherMethod::kPbgi ? "pbgi" : "fpbgi", rms, worst);
    EXPECT_LT(rms, 0.01);
    EXPECT_LT(worst, 0.05);
  }
}

}  // namespace
}  // namespace pbgi
