// Multiple bounces at build time: a closed emitting box (a "furnace") has
// an exact answer after B bounces, L = Le (1 + rho + ... + rho^(B-1)); the
// view-tree splatting (server/gather/view_tree_gather.h) must give the
// unsplatted bounce's answer.
#include "server/gather/surfel_bounce.h"
#include "common/errors.h"
#include "surfel_shapes.h"
#include "surfel_tree.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <tuple>
#include <vector>

namespace pbgi {
namespace {

using Imath::C3f;
using Imath::V3f;

// The inside of a 2 m box, every surfel emitting Le with albedo rho.
std::vector<Surfel> furnace(float Le, float rho) {
  std::vector<Surfel> s;
  const float S = 2.f;
  const uint32_t n = 40;
  test::add_quad(s, {0, 0, 0}, {S, 0, 0}, {0, S, 0}, n, n, C3f(Le));
  test::add_quad(s, {0, 0, S}, {0, S, 0}, {S, 0, 0}, n, n, C3f(Le));
  test::add_quad(s, {0, 0, 0}, {0, S, 0}, {0, 0, S}, n, n, C3f(Le));
  test::add_quad(s, {S, 0, 0}, {0, 0, S}, {0, S, 0}, n, n, C3f(Le));
  test::add_quad(s, {0, 0, 0}, {0, 0, S}, {S, 0, 0}, n, n, C3f(Le));
  test::add_quad(s, {0, S, 0}, {S, 0, 0}, {0, 0, S}, n, n, C3f(Le));
  for (Surfel& x : s) x.albedo = C3f(rho, rho, 0.f);  // blue reflects nothing
  return s;
}

// Bounce options: `bounces`, plain PBGI at every surfel, or the view tree.
BounceOptions plain(uint32_t bounces) {
  BounceOptions o;
  o.bounces = bounces;
  o.gather = GatherOptions{};
  o.splatting = false;
  o.receiver_stride = 1;
  return o;
}
BounceOptions splatted(uint32_t bounces) {
  BounceOptions o = plain(bounces);
  o.splatting = true;
  return o;
}

// The furnace's configurations: plain, splatted (both at every surfel), and
// the library's defaults (the coarse bounce).
enum class FurnaceConfig { kPlain, kSplatted, kDefaults };
std::string furnace_name(const ::testing::TestParamInfo<FurnaceConfig>& p) {
  return p.param == FurnaceConfig::kPlain ? "Plain" : p.param == FurnaceConfig::kSplatted ? "Splatted" : "Defaults";
}

class SurfelBounceFurnace : public ::testing::TestWithParam<FurnaceConfig> {};

TEST_P(SurfelBounceFurnace, ConvergesToTheGeometricSeries) {
  const float Le = 1.f, rho = 0.5f;
  for (uint32_t bounces = 1; bounces <= 4; ++bounces) {
    BounceOptions options = GetParam() == FurnaceConfig::kPlain ? plain(bounces) : splatted(bounces);
    if (GetParam() == FurnaceConfig::kDefaults) {
      options = BounceOptions{};
      options.bounces = bounces;
    }
    const std::vector<Surfel> out = add_bounces(furnace(Le, rho), options, tree::BuildOptions{});
    ASSERT_EQ(out.size(), 6u * 40u * 40u);
    double expect = 0, term = Le;
    for (uint32_t b = 0; b < bounces; ++b, term *= rho) expect += term;
    // Away from the box's edges every surfel sees the closed box.
    double sum = 0;
    size_t count = 0;
    for (const Surfel& s : out) {
      bool inner = true;
      for (int a = 0; a < 3; ++a) {
        if (std::abs(s.normal[a]) < 0.5f && (s.position[a] < 0.3f || s.position[a] > 1.7f))
          inner = false;
      }
      if (!inner) continue;
      sum += s.radiance.x;
      ++count;
      EXPECT_NEAR(s.radiance.x, expect, 0.02 * expect) << "bounces " << bounces;
      EXPECT_FLOAT_EQ(s.radiance.z, Le);  // no albedo: emission only
    }
    std::printf("furnace, %u bounce(s) %s: mean radiance %.4f, exact %.4f\n", bounces,
                furnace_name({GetParam(), 0}).c_str(), sum / double(count), expect);
    EXPECT_GT(count, 1000u);
  }
}

INSTANTIATE_TEST_SUITE_P(Configs, SurfelBounceFurnace,
                         ::testing::Values(FurnaceConfig::kPlain, FurnaceConfig::kSplatted, FurnaceConfig::kDefaults),
                         furnace_name);

TEST(SurfelBounce, FactorizedBouncesAgree) {
  BounceOptions o = plain(3);
  o.gather.method = GatherMethod::kFpbgi;
  const std::vector<Surfel> f = add_bounces(furnace(1.f, 0.5f), o, tree::BuildOptions{});
  const std::vector<Surfel> p = add_bounces(furnace(1.f, 0.5f), plain(3), tree::BuildOptions{});
  ASSERT_EQ(f.size(), p.size());
  double worst = 0;
  for (size_t i = 0; i < f.size(); ++i) {
    worst = std::max(worst, double(std::abs(f[i].radiance.x - p[i].radiance.x)));
  }
  std::printf("factorized vs plain bounces: worst radiance difference %.4f (of 1.75)\n", worst);
  EXPECT_LT(worst, 0.03);
}

TEST(SurfelBounce, GatherBounceAddsReflectedLightOnce) {
  // A white floor under an emitting disk: the floor's new radiance is its
  // direct term plus albedo/pi times the irradiance from the disk.
  std::vector<Surfel> s;
  test::add_disk(s, {0, 0, 2}, {0, 0, -1}, 1.f, 4000, C3f(1));  // E at origin: pi/5
  std::vector<Surfel> floor;
  test::add_quad(floor, {-0.1f, -0.1f, 0}, {0.2f, 0, 0}, {0, 0.2f, 0}, 4, 4, C3f(0.3f));
  for (Surfel& x : floor) {
    x.albedo = C3f(0.6f);
    x.emission = C3f(0);
  }
  s.insert(s.end(), floor.begin(), floor.end());
  test::SurfelTree tree(s);
  std::vector<C3f> direct(floor.size(), C3f(0.3f));
  gather_bounce(tree, floor, direct, plain(2));
  for (const Surfel& x : floor) {
    const float expect = 0.3f + 0.6f / 3.14159265f * (3.14159265f / 5.f);
    EXPECT_NEAR(x.radiance.x, expect, 0.01f);
  }
  std::vector<C3f> wrong(floor.size() + 1);
  EXPECT_THROW(gather_bounce(tree, floor, wrong, plain(2)), InvalidArgument);
  EXPECT_THROW(add_bounces(floor, plain(5), tree::BuildOptions{}), InvalidArgument);
  EXPECT_THROW(add_bounces(floor, plain(0), tree::BuildOptions{}), InvalidArgument);
}

// The box room (an emissive patch, two blocks: occlusion) with reflecting
// walls; returns the surfels' direct radiance as built.
std::vector<Surfel> reflecting_room(uint32_t target) {
  std::vector<Surfel> s = test::box_room(4.f, target);
  for (Surfel& x : s) {
    const bool light = x.radiance.x > 5.f;
    x.emission = light ? x.radiance : C3f(0.f);
    x.albedo = light ? C3f(0.f) : C3f(0.7f, 0.6f, 0.5f);
  }
  return s;
}

// The direct radiance (as built in `room`) of each surfel of `ordered`, a
// bounce's output in the tree's order, matched by position (the nearest
// surfel of `room`, within 1 cm: the tree stores positions quantized).
// A one-bounce add_bounces() returns its input unchanged, in the input's
// order: taking its radiances as those of a tree-ordered output paired
// surfels wrongly, lights among them, and gave a mean indirect radiance of
// 0.133 instead of about 0.22 to the relative figures below.
std::vector<Surfel> direct_in_order(const std::vector<Surfel>& room, const std::vector<Surfel>& ordered) {
  constexpr float kCell = 0.01f;
  const auto cell = [](const V3f& p, int dx, int dy, int dz) {
    return std::make_tuple(int(std::floor(p.x / kCell)) + dx, int(std::floor(p.y / kCell)) + dy,
                           int(std::floor(p.z / kCell)) + dz);
  };
  std::map<std::tuple<int, int, int>, std::vector<size_t>> grid;
  for (size_t i = 0; i < room.size(); ++i) grid[cell(room[i].position, 0, 0, 0)].push_back(i);
  std::vector<Surfel> out = ordered;
  size_t unmatched = 0;
  for (Surfel& s : out) {
    float best = kCell * kCell;
    const Surfel* match = nullptr;
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz) {
          const auto it = grid.find(cell(s.position, dx, dy, dz));
          if (it == grid.end()) continue;
          for (const size_t i : it->second) {
            const float d2 = (room[i].position - s.position).length2();
            if (d2 < best && room[i].normal.dot(s.normal) > 0.9f) {
              best = d2;
              match = &room[i];
            }
          }
        }
    if (match) {
      s.radiance = match->radiance;
    } else {
      ++unmatched;
    }
  }
  EXPECT_EQ(unmatched, 0u);
  return out;
}

// Relative RMS and worst relative difference of the indirect radiance
// (radiance - direct) of `a` against `b`, same surfels in the same order,
// over surfels that reflect; relative to b's mean indirect radiance.
struct IndirectDifference {
  double rel_rms = 0, rel_worst = 0, mean = 0;
};
IndirectDifference indirect_difference(const std::vector<Surfel>& a, const std::vector<Surfel>& b,
                                       const std::vector<Surfel>& direct) {
  double sum = 0, sum2 = 0, worst = 0;
  size_t n = 0;
  for (size_t i = 0; i < b.size(); ++i) {
    if (!(b[i].albedo.y > 0.f)) continue;
    const double ib = b[i].radiance.y - direct[i].radiance.y;
    const double d = double(a[i].radiance.y) - double(b[i].radiance.y);
    sum += ib;
    sum2 += d * d;
    worst = std::max(worst, std::abs(d));
    ++n;
  }
  IndirectDifference out;
  out.mean = sum / double(n);
  out.rel_rms = std::sqrt(sum2 / double(n)) / out.mean;
  out.rel_worst = worst / out.mean;
  return out;
}

TEST(SurfelBounce, SplattedBounceFollowsTheUnsplattedOne) {
  // add_bounces() returns the surfels in the tree's order.
  const std::vector<Surfel> room = reflecting_room(12000);
  const std::vector<Surfel> p = add_bounces(room, plain(2), tree::BuildOptions{});
  const std::vector<Surfel> direct = direct_in_order(room, p);
  BounceOptions fo = plain(2);
  fo.gather.method = GatherMethod::kFpbgi;
  const std::vector<Surfel> f = add_bounces(room, fo, tree::BuildOptions{});
  const std::vector<Surfel> v = add_bounces(room, splatted(2), tree::BuildOptions{});
  BounceOptions fine = splatted(2);
  fine.view_solid_angle = 0.0005f;
  const std::vector<Surfel> vf = add_bounces(room, fine, tree::BuildOptions{});
  ASSERT_EQ(direct.size(), room.size());
  ASSERT_EQ(v.size(), p.size());
  for (size_t i = 0; i < p.size(); ++i) ASSERT_EQ(v[i].position, p[i].position);
  const IndirectDifference vp = indirect_difference(v, p, direct);
  const IndirectDifference vfp = indirect_difference(vf, p, direct);
  const IndirectDifference fp = indirect_difference(f, p, direct);
  std::printf("[ measured ] room bounce, mean indirect %.4f, against PBGI: splatted rel rms %.4f, worst %.3f; "
              "splatted at 0.0005 sr %.4f, worst %.3f; FPBGI %.4f, worst %.3f\n",
              vp.mean, vp.rel_rms, vp.rel_worst, vfp.rel_rms, vfp.rel_worst, fp.rel_rms, fp.rel_worst);
  EXPECT_GT(vp.mean, 0.01);  // the room does reflect light
  // FPBGI, the unsplatted default, is within 1% of per-surfel PBGI here
  // (measured 0.0065 rms, worst 0.13). The splatted default trades some of
  // that for speed (docs/gather.md, 9b): measured 0.0172, worst 0.200.
  // Before surfaces were told apart within a depth cluster (microbuffer.h,
  // rule 3) the two agreed more closely (0.0075, worst 0.048, with this
  // mean; the bound on the worst surfel was 0.15), but both were further
  // from a ray-traced first bounce of the exact room: relative RMS 0.081
  // (plain) and 0.081 (splatted), mean +4.0% and +3.9%, against 0.075 and
  // 0.077, mean +0.2% and -0.1% now. The worst surfels lie in a band at the
  // height of the low block's top (z ~ 1), where the splatted bounce is
  // ~10% darker than both PBGI and the reference
  // (docs/measurements/2026-11-27-light-leak-speed-and-bounce.md).
  EXPECT_LT(vp.rel_rms, 0.02);
  EXPECT_LT(vp.rel_worst, 0.25);
  // At 0.0005 sr no sender of this small room is far from a receiver leaf
  // (4 surfels ~ 0.15 m across: far from 6 m): the receiver hierarchy
  // then only hands every surfel the root and its walk is PBGI's
  // (measured 0.0000).
  EXPECT_LT(vfp.rel_rms, 0.001);
  EXPECT_LT(vfp.rel_worst, 0.01);
}

TEST(SurfelBounce, CoarseBounceStaysNearTheFullOne) {
  // Three bounces in the reflecting room: the default (coarse: one surfel
  // in 16 gathered at N = 4 and 0.3 sr, the others interpolated) against
  // the full bounce (every surfel gathered at N = 8 and 0.03 sr, the
  // behaviour before the coarse options), both splatted.
  const std::vector<Surfel> room = reflecting_room(12000);
  BounceOptions full = splatted(3);
  full.gather.method = GatherMethod::kFpbgi;
  ASSERT_EQ(full.gather.microbuffer_resolution, 8u);
  ASSERT_EQ(full.gather.max_solid_angle, 0.03f);
  BounceOptions coarse;
  coarse.bounces = 3;
  ASSERT_GT(coarse.receiver_stride, 1u);  // the default is coarse
  BounceOptions sparse_only = full;
  sparse_only.receiver_stride = coarse.receiver_stride;
  const std::vector<Surfel> f = add_bounces(room, full, tree::BuildOptions{});
  const std::vector<Surfel> direct = direct_in_order(room, f);
  const std::vector<Surfel> c = add_bounces(room, coarse, tree::BuildOptions{});
  const std::vector<Surfel> s = add_bounces(room, sparse_only, tree::BuildOptions{});
  const IndirectDifference cf = indirect_difference(c, f, direct);
  const IndirectDifference sf = indirect_difference(s, f, direct);
  // Per-surfel radiance (direct + indirect), relative RMS.
  double sum2 = 0, sum = 0;
  size_t n = 0;
  for (size_t i = 0; i < f.size(); ++i) {
    if (!(f[i].albedo.y > 0.f)) continue;
    const double d = double(c[i].radiance.y) - double(f[i].radiance.y);
    sum2 += d * d;
    sum += f[i].radiance.y;
    ++n;
  }
  const double radiance_rel_rms = std::sqrt(sum2 / double(n)) / (sum / double(n));
  std::printf("[ measured ] room, 3 bounces, coarse default against full: radiance rel rms %.4f; indirect "
              "rel rms %.4f, worst %.3f (mean indirect %.4f); stride alone %.4f, worst %.3f\n",
              radiance_rel_rms, cf.rel_rms, cf.rel_worst, cf.mean, sf.rel_rms, sf.rel_worst);
  EXPECT_GT(cf.mean, 0.01);
  // Bounds ~1.5x what was measured: radiance 0.029, indirect 0.068
  // (worst 0.40), the stride alone 0.042 (worst 0.48; docs/gather.md,
  // section 9c), with a mean indirect radiance from misordered direct
  // radiances (direct_in_order); with the right one: radiance 0.025,
  // indirect 0.044 (worst 0.43), the stride alone 0.035 (worst 0.38).
  // The worst surfels lie next to a contact (a block on the floor), closer
  // to it than any representative.
  EXPECT_LT(radiance_rel_rms, 0.045);
  EXPECT_LT(cf.rel_rms, 0.10);
  EXPECT_LT(sf.rel_rms, 0.065);
}

TEST(SurfelBounce, CoarseBounceOptionsAreValidatedNamingTheField) {
  const auto message = [](const BounceOptions& b) {
    try {
      b.validate();
    } catch (const InvalidArgument& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  BounceOptions o;
  EXPECT_EQ(message(o), "");
  o.receiver_stride = 0;
  EXPECT_NE(message(o).find("bounce_receiver_stride"), std::string::npos) << message(o);
  o.receiver_stride = BounceOptions::kMaxReceiverStride + 1;
  EXPECT_NE(message(o).find("bounce_receiver_stride"), std::string::npos) << message(o);
  o.receiver_stride = 1;
  EXPECT_EQ(message(o), "");
  o.gather.microbuffer_resolution = 3;
  EXPECT_NE(message(o).find("bounce_microbuffer_resolution"), std::string::npos) << message(o);
  o.gather.microbuffer_resolution = 64;
  EXPECT_NE(message(o).find("bounce_microbuffer_resolution"), std::string::npos) << message(o);
  o.gather.microbuffer_resolution = 8;
  o.gather.max_solid_angle = 0.f;
  EXPECT_NE(message(o).find("bounce_max_solid_angle"), std::string::npos) << message(o);
  o.gather.max_solid_angle = std::nanf("");
  EXPECT_NE(message(o).find("bounce_max_solid_angle"), std::string::npos) << message(o);
  o.gather.max_solid_angle = 0.03f;
  EXPECT_EQ(message(o), "");
  std::vector<Surfel> floor;
  test::add_quad(floor, {0, 0, 0}, {1, 0, 0}, {0, 1, 0}, 4, 4, C3f(0.3f));
  o.bounces = 2;
  o.receiver_stride = 0;
  EXPECT_THROW(add_bounces(floor, o, tree::BuildOptions{}), InvalidArgument);
}

TEST(SurfelBounce, ViewSolidAngleIsValidated) {
  BounceOptions o;
  o.view_solid_angle = -0.01f;
  const auto message = [](const BounceOptions& b) {
    try {
      b.validate();
    } catch (const InvalidArgument& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(message(o).find("bounce_view_solid_angle"), std::string::npos) << message(o);
  o.view_solid_angle = BounceOptions::kMaxViewSolidAngle * 1.01f;
  EXPECT_NE(message(o).find("bounce_view_solid_angle"), std::string::npos);
  o.view_solid_angle = std::nanf("");
  EXPECT_NE(message(o).find("bounce_view_solid_angle"), std::string::npos);
  o.view_solid_angle = 0.f;  // auto
  EXPECT_EQ(message(o), "");
  // Half of FPBGI's split at the bounce gather's resolution: 0.1 rad at
  // the default N = 4, 0.05 at N = 8.
  ASSERT_EQ(o.gather.microbuffer_resolution, 4u);
  EXPECT_NEAR(o.effective_view_solid_angle(), 0.5f * 3.14159265f * 0.1f * 0.1f, 1e-6f);
  o.gather.microbuffer_resolution = 8;
  EXPECT_NEAR(o.effective_view_solid_angle(), 0.5f * 3.14159265f * 0.05f * 0.05f, 1e-6f);
  o.view_solid_angle = 0.02f;
  EXPECT_EQ(message(o), "");
  EXPECT_EQ(o.effective_view_solid_angle(), 0.02f);
  std::vector<Surfel> floor;
  test::add_quad(floor, {0, 0, 0}, {1, 0, 0}, {0, 1, 0}, 4, 4, C3f(0.3f));
  o.view_solid_angle = -1.f;
  EXPECT_THROW(add_bounces(floor, o, tree::BuildOptions{}), InvalidArgument);
}

}  // namespace
}  // namespace pbgi
