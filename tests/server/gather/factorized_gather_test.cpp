// Factorized PBGI (gather_tile with GatherMethod::kFpbgi): agreement with
// plain PBGI, the limits of its parameters, clustering, and the work it
// saves.
#include "common/errors.h"
#include "server/gather/gather.h"
#include "server/gather/receiver_clusters.h"
#include "surfel_shapes.h"
#include "surfel_tree.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <set>
#include <vector>

namespace pbgi {
namespace {

using Imath::C3f;
using Imath::V3f;

constexpr float kRoom = 4.f;

const test::SurfelTree& room() {
  static const std::unique_ptr<test::SurfelTree> tree =
      std::make_unique<test::SurfelTree>(test::box_room(kRoom, 40000));
  return *tree;
}

// A tile of n x n receivers 1 mm above the floor around (x, y), spacing h,
// and another on the red wall (x = 0), as two halves of one batch.
std::vector<Receiver> floor_and_wall_tile(float x, float y, float h, int n) {
  std::vector<Receiver> out;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) out.push_back({{x + h * i, y + h * j, 1e-3f}, {0, 0, 1}});
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) out.push_back({{1e-3f, y + h * i, 1.f + h * j}, {1, 0, 0}});
  return out;
}

std::vector<GatherResult> run(const tree::TreeSource& tree, const GatherOptions& o,
                              const std::vector<Receiver>& rs, GatherCounters* counters = nullptr) {
  Gatherer g(tree, o);
  std::vector<GatherResult> out(rs.size());
  g.gather_tile(rs, out);
  if (counters) *counters = g.counters();
  return out;
}

// Relative RMS difference of irradiance, and the largest relative one.
std::pair<double, double> difference(const std::vector<GatherResult>& a,
                                     const std::vector<GatherResult>& b) {
  double se = 0, norm = 0, worst = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    const double d = (a[i].irradiance - b[i].irradiance).length();
    const double m = b[i].irradiance.length();
    se += d * d;
    norm += m;
    if (m > 0) worst = std::max(worst, d / m);
  }
  return {std::sqrt(se / double(a.size())) / (norm / double(a.size())), worst};
}

GatherOptions fpbgi(uint32_t k = 100, float eps = 0.f) {  // eps 0: the default (auto)
  GatherOptions o;
  o.method = GatherMethod::kFpbgi;
  o.clusters = k;
  o.epsilon = eps;
  return o;
}

TEST(FactorizedGather, TinyEpsilonIsExactlyPbgi) {
  // Every node is near: each receiver walks from the root, nothing is
  // shared, results are bit-identical.
  const std::vector<Receiver> rs = floor_and_wall_tile(1.f, 2.f, 0.01f, 8);
  const std::vector<GatherResult> p = run(room(), GatherOptions{}, rs);
  const std::vector<GatherResult> f = run(room(), fpbgi(100, 1e-7f), rs);
  for (size_t i = 0; i < rs.size(); ++i) {
    EXPECT_EQ(f[i].irradiance.x, p[i].irradiance.x) << i;
    EXPECT_EQ(f[i].irradiance.z, p[i].irradiance.z) << i;
    EXPECT_EQ(f[i].ao, p[i].ao) << i;
  }
}

TEST(FactorizedGather, OneReceiverPerClusterMatchesPbgi) {
  // Clusters of one receiver have radius 0: everything is far, drawn into
  // the shared buffer and convolved through its moments.
  const std::vector<Receiver> rs = floor_and_wall_tile(1.f, 2.f, 0.05f, 4);
  const std::vector<GatherResult> p = run(room(), GatherOptions{}, rs);
  const std::vector<GatherResult> f = run(room(), fpbgi(1024, 0.01f), rs);
  const auto [rms, worst] = difference(f, p);
  std::printf("one receiver per cluster vs PBGI: rel rms %.4f, worst %.4f\n", rms, worst);
  EXPECT_LT(rms, 0.01);
  EXPECT_LT(worst, 0.03);
  for (size_t i = 0; i < rs.size(); ++i) EXPECT_NEAR(f[i].ao, p[i].ao, 0.01f) << i;
}

TEST(FactorizedGather, DefaultsAgreeWithPbgiAndSaveWork) {
  // A dense tile (2 mm spacing, like a 1k image of a 4 m room).
  const std::vector<Receiver> rs = floor_and_wall_tile(1.2f, 1.5f, 0.002f, 16);
  GatherCounters pc, fc;
  const std::vector<GatherResult> p = run(room(), GatherOptions{}, rs, &pc);
  const std::vector<GatherResult> f = run(room(), fpbgi(), rs, &fc);
  const auto [rms, worst] = difference(f, p);
  std::printf("FPBGI defaults vs PBGI: rel rms %.4f, worst %.4f; nodes per receiver %.0f vs %.0f, "
              "splats %.0f vs %.0f\n",
              rms, worst, double(fc.nodes_visited) / double(fc.receivers),
              double(pc.nodes_visited) / double(pc.receivers),
              double(fc.nodes_rasterized) / double(fc.receivers),
              double(pc.nodes_rasterized) / double(pc.receivers));
  EXPECT_EQ(fc.receivers, rs.size());
  EXPECT_LT(rms, 0.01);
  EXPECT_LT(worst, 0.04);
  EXPECT_LT(fc.nodes_visited, pc.nodes_visited / 3);
  EXPECT_LT(fc.nodes_rasterized, pc.nodes_rasterized / 3);
}

TEST(FactorizedGather, ErrorGrowsWithEpsilon) {
  const std::vector<Receiver> rs = floor_and_wall_tile(1.2f, 1.5f, 0.004f, 12);
  const std::vector<GatherResult> p = run(room(), GatherOptions{}, rs);
  double last_rms = -1;
  uint64_t last_nodes = ~uint64_t(0);
  for (const float eps : {0.005f, 0.02f, 0.1f}) {
    GatherCounters c;
    const std::vector<GatherResult> f = run(room(), fpbgi(100, eps), rs, &c);
    const double rms = difference(f, p).first;
    std::printf("epsilon %.3f: rel rms %.4f, nodes per receiver %.0f\n", eps, rms,
                double(c.nodes_visited) / double(c.receivers));
    EXPECT_LE(c.nodes_visited, last_nodes);
    EXPECT_GE(rms, last_rms - 1e-3);
    last_rms = rms;
    last_nodes = c.nodes_visited;
  }
  EXPECT_LT(last_rms, 0.05);
}

TEST(FactorizedGather, TranslatedTileGivesTheSameResult) {
  // The clustering and the cuts work relative to the receivers: a tile far
  // from the origin clusters the same. Positions on a 1/64 grid stay exact
  // at 1e5 (float spacing there is 1/128).
  std::vector<Surfel> s;
  test::add_disk(s, {0, 0, 2}, {0, 0, -1}, 1.f, 6000, C3f(1));
  test::add_quad(s, {-2, -2, 0}, {4, 0, 0}, {0, 4, 0}, 64, 64, C3f(0.2f));
  std::vector<Surfel> t = s;
  const V3f shift(1e5f, -1e5f, 1e5f);
  for (Surfel& x : t) x.position += shift;
  test::SurfelTree a(std::move(s)), b(std::move(t));
  std::vector<Receiver> ra, rb;
  for (int j = 0; j < 16; ++j)
    for (int i = 0; i < 16; ++i) {
      const V3f p(float(i) / 64.f, float(j) / 64.f, 1.f / 64.f);
      ra.push_back({p, {0, 0, 1}});
      rb.push_back({p + shift, {0, 0, 1}});
    }
  const std::vector<GatherResult> fa = run(a, fpbgi(16, 0.05f), ra);
  const std::vector<GatherResult> fb = run(b, fpbgi(16, 0.05f), rb);
  const auto [rms, worst] = difference(fb, fa);
  std::printf("translated by 1e5: rel rms %.5f, worst %.5f\n", rms, worst);
  EXPECT_LT(rms, 0.005);
  EXPECT_LT(worst, 0.02);
}

TEST(FactorizedGather, BatchesOfAnySizeWork) {
  const std::vector<Receiver> rs = floor_and_wall_tile(1.f, 2.f, 0.01f, 3);
  Gatherer g(room(), fpbgi());
  for (size_t n : {size_t(0), size_t(1), size_t(2), rs.size()}) {
    std::vector<GatherResult> out(n);
    g.gather_tile(std::span<const Receiver>(rs.data(), n), out);
    for (const GatherResult& r : out) {
      EXPECT_TRUE(std::isfinite(r.irradiance.x));
      EXPECT_GT(r.irradiance.x, 0.f);
    }
  }
}

TEST(FactorizedGather, InvalidBatchesThrow) {
  Gatherer g(room(), fpbgi());
  std::vector<Receiver> rs = floor_and_wall_tile(1.f, 2.f, 0.01f, 2);
  std::vector<GatherResult> out(rs.size() - 1);
  EXPECT_THROW(g.gather_tile(rs, out), InvalidArgument);
  out.resize(rs.size());
  rs[3].normal = V3f(0);
  EXPECT_THROW(g.gather_tile(rs, out), InvalidArgument);
  rs[3].normal = V3f(0, 0, 1);
  rs[2].position.x = std::nanf("");
  EXPECT_THROW(g.gather_tile(rs, out), InvalidArgument);
}

TEST(ReceiverClusters, SeparateNormalsAndCoverEveryReceiver) {
  const std::vector<Receiver> rs = floor_and_wall_tile(0.5f, 0.5f, 0.01f, 10);
  gather::ReceiverClusters c;
  c.build(rs, 20);
  std::set<uint32_t> seen;
  size_t total = 0;
  for (const gather::ReceiverCluster& k : c.clusters()) {
    ASSERT_GT(k.count, 0u);
    total += k.count;
    const V3f n0 = rs[c.members()[k.first]].normal;
    for (uint32_t m = k.first; m < k.first + k.count; ++m) {
      const uint32_t i = c.members()[m];
      seen.insert(i);
      // The floor and the wall never share a cluster.
      EXPECT_EQ(rs[i].normal, n0);
      EXPECT_LE((rs[i].position - k.frame.p).length(), k.frame.radius);
      EXPECT_LE((rs[i].normal - k.frame.n).length(), k.frame.normal_chord);
    }
    // The active receiver is a member.
    bool member = false;
    for (uint32_t m = k.first; m < k.first + k.count; ++m) member |= c.members()[m] == k.active;
    EXPECT_TRUE(member);
  }
  EXPECT_EQ(total, rs.size());
  EXPECT_EQ(seen.size(), rs.size());
  EXPECT_LE(c.clusters().size(), 20u);
  EXPECT_GE(c.clusters().size(), 10u);
}

}  // namespace
}  // namespace pbgi
