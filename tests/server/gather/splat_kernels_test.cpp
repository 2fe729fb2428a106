// The SIMD splat kernel (server/gather/splat_kernels.h) gives the same bits
// on every Highway target compiled in and supported by this CPU (the
// scalar fallback included): its outputs, the microbuffers it rasterizes
// and whole gathers. Batched splats draw exactly what one-by-one splats do.
#include "server/gather/cube_layout.h"
#include "server/gather/gather.h"
#include "server/gather/microbuffer.h"
#include "server/gather/rasterizer.h"
#include "server/gather/splat_kernels.h"
#include "surfel_shapes.h"
#include "surfel_tree.h"

#include <hwy/highway.h>

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>
#include <string>
#include <vector>

namespace pbgi::gather {
namespace {

using Imath::C3f;
using Imath::V3f;

// Every target the kernel may run with here: the compiled ones (HWY_TARGETS
// of this file, built with the same flags as the kernel's) this CPU has,
// plus the scalar fallback any x86-64 runs.
std::vector<int64_t> runnable_targets() {
  std::vector<int64_t> out;
  for (int64_t t = HWY_TARGETS; t != 0; t &= t - 1) {
    const int64_t target = t & -t;
    if ((hwy::SupportedTargets() & target) || target == HWY_SCALAR || target == HWY_EMU128) {
      out.push_back(target);
    }
  }
  return out;
}

// Runs f() with the kernel dispatched to `target`, then restores the
// CPU's own choice.
template <class F>
void with_target(int64_t target, const F& f) {
  hwy::SetSupportedTargetsForTest(target);
  try {
    f();
  } catch (...) {
    hwy::SetSupportedTargetsForTest(0);
    throw;
  }
  hwy::SetSupportedTargetsForTest(0);
}

uint32_t bits(float f) {
  uint32_t b;
  std::memcpy(&b, &f, sizeof b);
  return b;
}

// Random splats of every kind the gather makes: round and squashed, sub-
// pixel to several pixels, near face edges and corners, with and without
// a squash direction along the view.
struct RandomSplat {
  V3f dir;
  Rasterizer::Shape shape;
  float depth;
  C3f radiance;
};

std::vector<RandomSplat> random_splats(uint32_t count, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> U(-1.f, 1.f), P(0.f, 1.f);
  std::vector<RandomSplat> out(count);
  for (uint32_t i = 0; i < count; ++i) {
    RandomSplat& s = out[i];
    s.dir = i % 11 == 0 ? V3f(1.f, 1.f, U(rng)) : V3f(U(rng), U(rng), U(rng));
    s.dir.normalize();
    s.shape.omega = std::pow(10.f, -5.f + 4.f * P(rng));
    s.shape.ratio = i % 3 == 0 ? 1.f : 0.02f + P(rng);
    s.shape.squash = i % 13 == 0 ? s.dir : V3f(U(rng), U(rng), U(rng)).normalized();
    s.shape.max_radius = i % 7 == 0 ? 1e30f : 0.3f * P(rng);
    s.shape.depth_extent = i % 5 == 0 ? 0.1f * P(rng) : 0.f;
    s.depth = 0.5f + 4.f * P(rng);
    s.radiance = C3f(P(rng), P(rng), P(rng));
  }
  return out;
}

TEST(SplatKernel, SameBitsOnEveryTarget) {
  const std::vector<int64_t> targets = runnable_targets();
  ASSERT_FALSE(targets.empty());
  for (const uint32_t n : {4u, 8u, 16u, 32u}) {
    const CubeLayout& layout = CubeLayout::get(n);
    const SplatLayout sl{n, layout.pixel_width(), 1.f / layout.pixel_width(),
                         layout.solid_angles()};
    const std::vector<RandomSplat> splats = random_splats(SplatBatch::kCapacity, n);
    std::vector<std::unique_ptr<SplatBatch>> out;
    for (const int64_t target : targets) {
      auto b = std::make_unique<SplatBatch>();
      for (const RandomSplat& s : splats) {
        const size_t i = b->size++;
        b->dx[i] = s.dir.x;
        b->dy[i] = s.dir.y;
        b->dz[i] = s.dir.z;
        b->omega[i] = s.shape.omega;
        b->ratio[i] = s.shape.ratio;
        b->max_radius[i] = s.shape.max_radius;
        b->sx[i] = s.shape.squash.x;
        b->sy[i] = s.shape.squash.y;
        b->sz[i] = s.shape.squash.z;
      }
      with_target(target, [&] { run_splat_kernel(sl, *b); });
      out.push_back(std::move(b));
    }
    const SplatBatch& ref = *out[0];
    size_t inside = 0;
    for (size_t i = 0; i < ref.size; ++i) {
      // The fast path's masses are a partition of unity.
      if (ref.inside[i]) {
        ++inside;
        float su = 0.f, sv = 0.f;
        for (int32_t c = 0; c < ref.ni[i]; ++c) su += ref.mu[c][i];
        for (int32_t r = 0; r < ref.nj[i]; ++r) sv += ref.mv[r][i];
        EXPECT_NEAR(su, 1.f, 1e-5f);
        EXPECT_NEAR(sv, 1.f, 1e-5f);
      }
      // pi * major * minor = omega.
      EXPECT_NEAR(3.14159265f * ref.major[i] * ref.minor[i], splats[i].shape.omega,
                  1e-5f * splats[i].shape.omega);
    }
    EXPECT_GT(inside, ref.size / 4) << "N " << n;
    EXPECT_LT(inside, ref.size) << "N " << n;
    for (size_t t = 1; t < targets.size(); ++t) {
      const SplatBatch& b = *out[t];
      const std::string where = std::string(hwy::TargetName(targets[t])) + " vs " +
                                hwy::TargetName(targets[0]) + ", N " + std::to_string(n);
      for (size_t i = 0; i < ref.size; ++i) {
        EXPECT_EQ(bits(b.major[i]), bits(ref.major[i])) << where << " splat " << i;
        EXPECT_EQ(bits(b.minor[i]), bits(ref.minor[i])) << where << " splat " << i;
        EXPECT_EQ(bits(b.u[i]), bits(ref.u[i])) << where << " splat " << i;
        EXPECT_EQ(bits(b.v[i]), bits(ref.v[i])) << where << " splat " << i;
        EXPECT_EQ(bits(b.hu[i]), bits(ref.hu[i])) << where << " splat " << i;
        EXPECT_EQ(bits(b.hv[i]), bits(ref.hv[i])) << where << " splat " << i;
        EXPECT_EQ(b.home[i], ref.home[i]) << where << " splat " << i;
        EXPECT_EQ(b.inside[i], ref.inside[i]) << where << " splat " << i;
        EXPECT_EQ(b.i0[i], ref.i0[i]) << where << " splat " << i;
        EXPECT_EQ(b.j0[i], ref.j0[i]) << where << " splat " << i;
        EXPECT_EQ(b.ni[i], ref.ni[i]) << where << " splat " << i;
        EXPECT_EQ(b.nj[i], ref.nj[i]) << where << " splat " << i;
        EXPECT_EQ(bits(b.covered[i]), bits(ref.covered[i])) << where << " splat " << i;
        for (int32_t c = 0; c < ref.ni[i]; ++c) {
          EXPECT_EQ(bits(b.mu[c][i]), bits(ref.mu[c][i])) << where << " splat " << i;
        }
        for (int32_t r = 0; r < ref.nj[i]; ++r) {
          EXPECT_EQ(bits(b.mv[r][i]), bits(ref.mv[r][i])) << where << " splat " << i;
        }
      }
    }
  }
}

// Every pixel's resolved light after `splats` (queued in batches when
// `batched`, else drawn one by one), and the irradiance and AO.
struct Drawn {
  std::vector<PixelLight> light;
  Resolved resolved;
};

Drawn draw(uint32_t n, const std::vector<RandomSplat>& splats, bool batched) {
  const CubeLayout& layout = CubeLayout::get(n);
  Microbuffer mb(layout, 0.1f);
  Rasterizer raster(mb);
  mb.begin(V3f(0.2f, -0.3f, 0.9f).normalized());
  for (const RandomSplat& s : splats) {
    if (batched) {
      raster.queue(s.dir, s.shape, s.depth, s.radiance);
    } else {
      raster.splat(s.dir, s.shape, s.depth, s.radiance);
    }
  }
  // A ray-cast disk draws the queued splats first.
  raster.raycast(V3f(0.f, 0.f, 0.4f), V3f(0.f, 0.f, -1.f), 0.2f, C3f(2.f));
  raster.flush();
  Drawn out;
  out.resolved = mb.resolve(0.f, nullptr, nullptr, &out.light);
  return out;
}

void expect_same(const Drawn& a, const Drawn& b, const std::string& where) {
  EXPECT_EQ(bits(a.resolved.irradiance.x), bits(b.resolved.irradiance.x)) << where;
  EXPECT_EQ(bits(a.resolved.irradiance.y), bits(b.resolved.irradiance.y)) << where;
  EXPECT_EQ(bits(a.resolved.irradiance.z), bits(b.resolved.irradiance.z)) << where;
  EXPECT_EQ(bits(a.resolved.ao), bits(b.resolved.ao)) << where;
  ASSERT_EQ(a.light.size(), b.light.size()) << where;
  for (size_t i = 0; i < a.light.size(); ++i) {
    EXPECT_EQ(a.light[i].pixel, b.light[i].pixel) << where;
    EXPECT_EQ(bits(a.light[i].light.x), bits(b.light[i].light.x)) << where << " pixel " << i;
    EXPECT_EQ(bits(a.light[i].light.y), bits(b.light[i].light.y)) << where << " pixel " << i;
    EXPECT_EQ(bits(a.light[i].light.z), bits(b.light[i].light.z)) << where << " pixel " << i;
  }
}

TEST(SplatKernel, MicrobufferIsTheSameOnEveryTargetAndBatchedOrNot) {
  // 300 splats: several full batches and a partial one.
  const std::vector<RandomSplat> splats = random_splats(300, 99);
  for (const uint32_t n : {8u, 16u}) {
    const Drawn one_by_one = draw(n, splats, false);
    ASSERT_GT(one_by_one.light.size(), 50u);
    for (const int64_t target : runnable_targets()) {
      Drawn batched;
      with_target(target, [&] { batched = draw(n, splats, true); });
      expect_same(batched, one_by_one,
                  std::string(hwy::TargetName(target)) + ", N " + std::to_string(n));
    }
  }
}

TEST(SplatKernel, GatherIsTheSameOnEveryTarget) {
  const test::SurfelTree tree(test::box_room(4.f, 20000));
  std::vector<Receiver> receivers;
  for (int i = 0; i < 8; ++i) {
    receivers.push_back({V3f(-1.5f + 0.4f * float(i), 0.3f, 0.001f), V3f(0, 0, 1)});
    receivers.push_back({V3f(1.999f, -1.f + 0.25f * float(i), 1.5f), V3f(-1, 0, 0)});
  }
  for (const GatherMethod method : {GatherMethod::kPbgi, GatherMethod::kFpbgi}) {
    GatherOptions o;
    o.method = method;
    std::vector<std::vector<GatherResult>> results;
    for (const int64_t target : runnable_targets()) {
      std::vector<GatherResult> r(receivers.size());
      with_target(target, [&] {
        Gatherer g(tree, o);
        g.gather_tile(receivers, r);
      });
      results.push_back(std::move(r));
    }
    for (size_t t = 1; t < results.size(); ++t) {
      for (size_t i = 0; i < receivers.size(); ++i) {
        const GatherResult &a = results[t][i], &b = results[0][i];
        EXPECT_GT(b.irradiance.x, 0.f);
        EXPECT_EQ(bits(a.irradiance.x), bits(b.irradiance.x)) << "receiver " << i;
        EXPECT_EQ(bits(a.irradiance.y), bits(b.irradiance.y)) << "receiver " << i;
        EXPECT_EQ(bits(a.irradiance.z), bits(b.irradiance.z)) << "receiver " << i;
        EXPECT_EQ(bits(a.ao), bits(b.ao)) << "receiver " << i;
      }
    }
  }
}

}  // namespace
}  // namespace pbgi::gather
