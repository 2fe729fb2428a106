#include "storage/codecs/wavelet_tree_coding.h"
#include "common/errors.h"
#include "storage/codecs/cube_wavelet.h"
#include "tests/storage/codecs/node_payloads.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>

namespace pbgi::storage {
namespace {

// A test-level tree of glossy surfels: a binary median-split hierarchy over
// random positions; each leaf is one surfel whose outgoing radiance (a
// glossy lobe towards a light-dependent mirror direction) is a Haar cube
// map. Nodes are in pre-order.
struct GlossyTree {
  CubeLayout layout{8};
  WaveletTreeTopology topology;
  std::vector<std::vector<float>> leaf;  // per node; empty for internal nodes

  GlossyTree(size_t surfels, uint32_t seed, bool equal_areas) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.f, 1.f);
    std::vector<Imath::V3f> pos(surfels);
    for (auto& p : pos) p = Imath::V3f(u(rng), u(rng), u(rng));
    std::vector<uint32_t> idx(surfels);
    std::iota(idx.begin(), idx.end(), 0u);
    const Imath::V3f light(0.5f, 3.f, 0.5f);
    build(idx, 0, surfels, pos, light, rng, equal_areas);
  }

  uint32_t build(std::vector<uint32_t>& idx, size_t b, size_t e, const std::vector<Imath::V3f>& pos,
                 const Imath::V3f& light, std::mt19937& rng, bool equal_areas) {
    const uint32_t me = uint32_t(topology.nodes.size());
    topology.nodes.emplace_back();
    leaf.emplace_back();
    if (e - b == 1) {
      std::uniform_real_distribution<float> u(0.f, 1.f);
      const Imath::V3f p = pos[idx[b]];
      // Normals vary smoothly with position, so siblings look alike.
      const Imath::V3f n = Imath::V3f(p.x - 0.5f, 1.f, p.z - 0.5f).normalized();
      const Imath::V3f to_light = (light - p).normalized();
      const Imath::V3f mirror = 2.f * n.dot(to_light) * n - to_light;
      const float rough = 0.1f + 0.2f * p.y;
      auto L = [&](const Imath::V3f& w) {
        return glossy_radiance(n, mirror, rough, {0.1f, 0.1f, 0.1f}, {1.f, 0.9f, 0.6f}, w);
      };
      auto c = sample_cube(layout, L);
      cube_forward(layout, c);
      leaf[me] = std::move(c);
      topology.nodes[me].area = equal_areas ? 1.f : 0.2f + u(rng);
      return me;
    }
    const size_t mid = b + (e - b) / 2;
    std::nth_element(idx.begin() + b, idx.begin() + mid, idx.begin() + e,
                     [&](uint32_t x, uint32_t y) { return pos[x].x + 0.3f * pos[x].z < pos[y].x + 0.3f * pos[y].z; });
    const uint32_t l = build(idx, b, mid, pos, light, rng, equal_areas);
    const uint32_t r = build(idx, mid, e, pos, light, rng, equal_areas);
    auto& n = topology.nodes[me];
    n.child_count = 2;
    n.children[0] = l;
    n.children[1] = r;
    n.area = topology.nodes[l].area + topology.nodes[r].area;
    return me;
  }

  LeafCoefficients leaves() const {
    return [this](uint32_t i) { return std::span<const float>(leaf[i]); };
  }
  size_t dims() const { return layout.floats(); }
};

double max_abs(const std::vector<float>& v) {
  double m = 0;
  for (float x : v) m = std::max(m, double(std::abs(x)));
  return m;
}

TEST(WaveletTreeCoding, ZeroThresholdReconstructsEveryNode) {
  for (bool equal : {true, false}) {
    const GlossyTree t(300, 1, equal);
    const size_t dims = t.dims();
    const auto exact = wavelet_tree_averages(t.topology, dims, t.leaves());
    const double scale = max_abs(exact);
    for (uint32_t m : {0u, 3u, 100u}) {
      WaveletCodingOptions o;
      o.average_levels = m;
      const WaveletTreeCode code = encode_wavelet_tree(t.topology, dims, t.leaves(), o);
      EXPECT_EQ(code.dropped_blocks, 0u);
      WaveletTreeDecoder dec(code, t.topology, 64);
      for (uint32_t i = 0; i < t.topology.nodes.size(); ++i) {
        const auto v = dec.reconstruct(i);
        for (size_t k = 0; k < dims; ++k) {
          ASSERT_NEAR(v[k], exact[size_t(i) * dims + k], 2e-6 * scale) << "m " << m << " node " << i;
        }
      }
    }
  }
}

TEST(WaveletTreeCoding, NodesAverageTheirLeavesRadiance) {
  // Haar is linear: the root's cube map is the area-weighted mean of the
  // leaves' radiance in every direction.
  const GlossyTree t(64, 2, false);
  const auto exact = wavelet_tree_averages(t.topology, t.dims(), t.leaves());
  const Imath::V3f w = Imath::V3f(0.3f, 0.8f, -0.2f).normalized();
  double sum = 0, area = 0;
  for (uint32_t i = 0; i < t.topology.nodes.size(); ++i) {
    if (t.topology.nodes[i].child_count) continue;
    sum += t.topology.nodes[i].area * cube_evaluate(t.layout, t.leaf[i], w).x;
    area += t.topology.nodes[i].area;
  }
  const std::span<const float> root(exact.data(), t.dims());
  EXPECT_NEAR(cube_evaluate(t.layout, root, w).x, sum / area, 1e-4 * (1 + sum / area));
}

TEST(WaveletTreeCoding, ThresholdErrorIsBoundedByDroppedNorms) {
  const GlossyTree t(400, 3, false);
  const size_t dims = t.dims();
  const auto exact = wavelet_tree_averages(t.topology, dims, t.leaves());
  std::vector<uint32_t> parent, depth;
  t.topology.parents(parent, depth);
  const WaveletTreeCode full = encode_wavelet_tree(t.topology, dims, t.leaves(), {2, 0.f, 0});
  // Threshold: the median norm of the exact detail vectors (per block size).
  for (uint32_t block : {0u, uint32_t(t.layout.face_floats()), uint32_t(t.layout.image_floats())}) {
    const size_t bsize = block ? block : dims;
    std::vector<double> norms;
    for (const auto& n : t.topology.nodes) {
      if (n.child_count != 2) continue;
      for (size_t b0 = 0; b0 < dims; b0 += bsize) {
        double s2 = 0;
        for (size_t k = b0; k < b0 + bsize; ++k) {
          const double h = 0.5 * (double(exact[n.children[0] * dims + k]) - exact[n.children[1] * dims + k]);
          s2 += h * h;
        }
        norms.push_back(std::sqrt(s2));
      }
    }
    std::nth_element(norms.begin(), norms.begin() + norms.size() / 2, norms.end());
    WaveletCodingOptions o;
    o.average_levels = 2;
    o.threshold = float(norms[norms.size() / 2]);
    o.block_floats = block;
    const WaveletTreeCode code = encode_wavelet_tree(t.topology, dims, t.leaves(), o);
    ASSERT_GT(code.dropped_blocks, 0u) << block;
    EXPECT_LT(code.details.size(), full.details.size());
    const size_t bf = code.block_floats;
    // Per node: bound = sum over its path of |s_k| * |dropped part of H_k|,
    // with H_k from the exact averages.
    std::vector<double> bound(t.topology.nodes.size(), 0.0);
    for (uint32_t i = 1; i < t.topology.nodes.size(); ++i) {  // pre-order: parents first
      const uint32_t p = parent[i];
      const auto& pn = t.topology.nodes[p];
      bound[i] = bound[p];
      if (pn.child_count != 2 || !code.has_detail[p]) continue;
      const uint32_t a = pn.children[0], b = pn.children[1];
      const double wa = t.topology.nodes[a].area / (t.topology.nodes[a].area + t.topology.nodes[b].area);
      const double s = i == a ? 2 * (1 - wa) : 2 * wa;
      double dropped2 = 0;
      for (size_t blk = 0; blk < code.blocks(); ++blk) {
        if (code.detail_mask[p] >> blk & 1) continue;
        for (size_t k = blk * bf; k < (blk + 1) * bf; ++k) {
          const double h = 0.5 * (double(exact[a * dims + k]) - exact[b * dims + k]);
          dropped2 += h * h;
        }
      }
      bound[i] += s * std::sqrt(dropped2);
    }
    WaveletTreeDecoder dec(code, t.topology);
    const double eps = 1e-5 * max_abs(exact);
    size_t lossy = 0;
    for (uint32_t i = 0; i < t.topology.nodes.size(); ++i) {
      const auto v = dec.reconstruct(i);
      double err2 = 0;
      for (size_t k = 0; k < dims; ++k) err2 += std::pow(double(v[k]) - exact[size_t(i) * dims + k], 2);
      ASSERT_LE(std::sqrt(err2), bound[i] + eps) << "block " << block << " node " << i;
      lossy += bound[i] > 0;
    }
    EXPECT_GT(lossy, 0u);
  }
}

TEST(WaveletTreeCoding, TopDownTraversalTakesOneStepPerNode) {
  const GlossyTree t(256, 4, true);
  const WaveletTreeCode code = encode_wavelet_tree(t.topology, t.dims(), t.leaves(), {1, 0.f, 0});
  WaveletTreeDecoder dec(code, t.topology, 64);
  // Depth-first pre-order = parents before children: each node below level 1
  // starts from its cached parent.
  for (uint32_t i = 0; i < t.topology.nodes.size(); ++i) dec.reconstruct(i);
  std::vector<uint32_t> parent, depth;
  t.topology.parents(parent, depth);
  size_t below = 0;
  for (uint32_t d : depth) below += d > 1;
  EXPECT_EQ(dec.detail_steps(), below);
  // Random access from a cold cache walks the path from the level-m anchor.
  WaveletTreeDecoder cold(code, t.topology, 8);
  const uint32_t deepest = uint32_t(std::max_element(depth.begin(), depth.end()) - depth.begin());
  cold.reconstruct(deepest);
  EXPECT_EQ(cold.detail_steps(), depth[deepest] - 1);
}

TEST(WaveletTreeCoding, SerializationRoundTrip) {
  const GlossyTree t(128, 5, false);
  WaveletCodingOptions o;
  o.average_levels = 2;
  o.threshold = 0.02f;
  o.block_floats = uint32_t(t.layout.face_floats());
  const WaveletTreeCode code = encode_wavelet_tree(t.topology, t.dims(), t.leaves(), o);
  const auto bytes = code.serialize();
  const WaveletTreeCode back = WaveletTreeCode::deserialize(bytes, "w");
  EXPECT_EQ(back.averages.size(), code.averages.size());
  EXPECT_EQ(back.details.size(), code.details.size());
  EXPECT_EQ(back.detail_mask, code.detail_mask);
  EXPECT_EQ(back.serialize(), bytes);
  WaveletTreeDecoder a(code, t.topology), b(back, t.topology);
  for (uint32_t i = 0; i < t.topology.nodes.size(); i += 7) {
    const auto va = a.reconstruct(i);
    const std::vector<float> copy(va.begin(), va.end());
    const auto vb = b.reconstruct(i);
    ASSERT_TRUE(std::equal(copy.begin(), copy.end(), vb.begin()));
  }
  auto damaged = bytes;
  damaged[damaged.size() / 2] ^= 0x10;
  EXPECT_THROW(WaveletTreeCode::deserialize(damaged, "w"), CorruptionError);
  // Stored size shrinks with the threshold.
  const auto full = encode_wavelet_tree(t.topology, t.dims(), t.leaves(), {2, 0.f, o.block_floats}).serialize();
  EXPECT_LT(bytes.size(), full.size());
}

TEST(WaveletTreeCoding, RejectsBadTrees) {
  WaveletTreeTopology t;
  t.nodes.resize(3);
  t.nodes[0].child_count = 2;
  t.nodes[0].children[0] = 1;
  t.nodes[0].children[1] = 1;  // a node with two links to it
  EXPECT_THROW(t.validate(), InvalidArgument);
  t.nodes[0].children[1] = 2;
  EXPECT_NO_THROW(t.validate());
  WaveletCodingOptions o;
  o.block_floats = 7;
  EXPECT_THROW(o.validate(36), InvalidArgument);
}

}  // namespace
}  // namespace pbgi::storage
