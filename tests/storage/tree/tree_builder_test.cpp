// Invariants of the built tree on random surfels: bounds enclose, cones
// contain, areas add up, payloads average, structure is a proper binary
// tree over a partition of the surfels in Morton order, and the stored
// (quantized) surfels are within the documented precision of the input.
#include "storage/tree/tree_builder.h"

#include "common/errors.h"
#include "storage/format/packed_values.h"
#include "storage/sh/sh.h"
#include "storage/tree/memory_tree.h"
#include "storage/tree/morton.h"
#include "tests/storage/tree/random_surfels.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace pbgi::tree {
namespace {

using Vec36 = std::array<double, 36>;

Vec36 payload_of(const Node& n) {
  Vec36 v{};
  for (int i = 0; i < 9; ++i) {
    v[i] = n.radiance_sh.r[i];
    v[9 + i] = n.radiance_sh.g[i];
    v[18 + i] = n.radiance_sh.b[i];
    v[27 + i] = n.coverage_sh[i];
  }
  return v;
}

// Reference payload straight from the definition in node.h, in double.
Vec36 reference_payload(const Surfel* s, size_t count, double* area_out) {
  Vec36 sum{};
  double area = 0;
  for (size_t k = 0; k < count; ++k) {
    const double a = M_PI * double(s[k].radius) * s[k].radius;
    const sh::Sh9 lobe = sh::clamped_cosine(s[k].normal);
    for (int i = 0; i < 9; ++i) {
      sum[i] += a * s[k].radiance.x * lobe[i];
      sum[9 + i] += a * s[k].radiance.y * lobe[i];
      sum[18 + i] += a * s[k].radiance.z * lobe[i];
      sum[27 + i] += a * lobe[i];
    }
    area += a;
  }
  for (double& x : sum) x /= area;
  *area_out = area;
  return sum;
}

// max_i |a_i - b_i| relative to max_i |b_i|.
double relative_error(const Vec36& a, const Vec36& b) {
  double err = 0, scale = 0;
  for (int i = 0; i < 36; ++i) {
    err = std::max(err, std::abs(a[i] - b[i]));
    scale = std::max(scale, std::abs(b[i]));
  }
  return err / std::max(scale, 1e-30);
}

// The order build_tree() stores surfels in: Morton code, then input index.
std::vector<uint32_t> morton_order(const std::vector<Surfel>& in) {
  const MortonFrame frame(surfel_bounds(in));
  std::vector<uint32_t> order(in.size());
  for (uint32_t i = 0; i < in.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
    return frame.code(in[a].position) < frame.code(in[b].position);
  });
  return order;
}

struct Range {
  uint32_t begin = std::numeric_limits<uint32_t>::max(), end = 0;
};

class TreeInvariants : public ::testing::TestWithParam<uint32_t> {};

TEST_P(TreeInvariants, HoldOnRandomSurfels) {
  const uint32_t leaf_size = GetParam();
  const size_t n = 3000;
  std::vector<Surfel> input = test::random_surfels(n, 42 + leaf_size);
  BuildOptions opt;
  opt.leaf_size = leaf_size;
  const BuiltTree t = build_tree(input, opt);

  ASSERT_EQ(t.surfels.size(), n);

  // The surfels are the input in Morton order (ties in input order), each
  // within the documented precision of its input (storage/tree/page_records.h).
  const std::vector<uint32_t> sorted = morton_order(input);
  std::vector<float> leaf_radius(n, 0.f);
  for (const Node& node : t.nodes)
    if (node.is_leaf())
      for (uint32_t k = 0; k < node.surfel_count; ++k) leaf_radius[node.first_surfel + k] = node.radius;
  for (size_t i = 0; i < n; ++i) {
    const Surfel& in = input[sorted[i]];
    const Surfel& got = t.surfels[i];
    const float R = leaf_radius[i];
    const float ulp = 4 * std::numeric_limits<float>::epsilon() * (in.position.length() + R);
    // Compact records (the leaf format relative in the pages this build
    // writes): positions R/16382 per coordinate, or on a coarser grid of
    // steps of at most r/32 (a step near the frame's edge), the radius
    // R/16382, 12-bit octahedral normals, the emission out of line but
    // RGB9E5 as ever.
    for (int k = 0; k < 3; ++k) {
      ASSERT_NEAR(got.position[k], in.position[k], std::max(R / 16382, in.radius / 32) + ulp) << i;
    }
    ASSERT_NEAR(got.radius, in.radius, R / 16382 + 1e-7f) << i;
    const Imath::V3d a(got.normal.x, got.normal.y, got.normal.z), b(in.normal.x, in.normal.y, in.normal.z);
    ASSERT_LE(std::atan2(a.cross(b).length(), a.dot(b)), storage::kOctahedral12MaxAngle) << i;
    ASSERT_EQ(got.emission, storage::decode_rgb9e5(storage::encode_rgb9e5(in.emission))) << i;
    for (int k = 0; k < 3; ++k) {
      ASSERT_NEAR(got.radiance[k], in.radiance[k], std::max({in.radiance.x, in.radiance.y, in.radiance.z}) / 512);
      ASSERT_NEAR(got.albedo[k], in.albedo[k], std::max({in.albedo.x, in.albedo.y, in.albedo.z}) / 512);
    }
  }

  // Walk from the root: every node once, children after parents, leaves
  // partition the surfels; compute each subtree's surfel range.
  std::vector<Range> range(t.nodes.size());
  std::vector<uint32_t> depth(t.nodes.size(), 0), order;
  std::vector<int> seen(t.nodes.size(), 0);
  std::vector<int> surfel_seen(n, 0);
  std::vector<uint32_t> stack{0};
  uint64_t leaves = 0;
  uint32_t max_depth = 0;
  while (!stack.empty()) {
    const uint32_t i = stack.back();
    stack.pop_back();
    ASSERT_LT(i, t.nodes.size());
    ASSERT_EQ(seen[i]++, 0) << "node " << i << " reached twice";
    order.push_back(i);
    const Node& node = t.nodes[i];
    if (node.is_leaf()) {
      ++leaves;
      max_depth = std::max(max_depth, depth[i]);
      ASSERT_GE(node.surfel_count, 1u);
      ASSERT_LE(node.surfel_count, leaf_size);
      for (uint32_t k = node.first_surfel; k < node.first_surfel + node.surfel_count; ++k) surfel_seen[k]++;
      range[i] = {node.first_surfel, node.first_surfel + node.surfel_count};
    } else {
      ASSERT_EQ(node.child_count, 2u);
      for (uint32_t c = 0; c < 2; ++c) {
        ASSERT_EQ(node.children[c].page, 0u);
        ASSERT_GT(node.children[c].index, i);  // pre-order
        depth[node.children[c].index] = depth[i] + 1;
        stack.push_back(node.children[c].index);
      }
    }
  }
  ASSERT_EQ(std::count(seen.begin(), seen.end(), 1), long(t.nodes.size()));
  ASSERT_EQ(std::count(surfel_seen.begin(), surfel_seen.end(), 1), long(n));
  EXPECT_EQ(leaves, t.leaf_count);
  EXPECT_EQ(max_depth, t.max_depth);
  // Radix splits: at most one level per key bit (63 of Morton code, then
  // index bits for equal codes).
  EXPECT_LE(max_depth, 128u);

  // Subtree ranges, bottom-up (reverse pre-order).
  for (auto it = order.rbegin(); it != order.rend(); ++it) {
    const Node& node = t.nodes[*it];
    if (node.is_leaf()) continue;
    const Range& l = range[node.children[0].index];
    const Range& r = range[node.children[1].index];
    ASSERT_EQ(l.end, r.begin) << "subtree surfels are contiguous";
    range[*it] = {l.begin, r.end};
  }
  EXPECT_EQ(range[0].begin, 0u);
  EXPECT_EQ(range[0].end, n);

  for (size_t i = 0; i < t.nodes.size(); ++i) {
    const Node& node = t.nodes[i];
    const float tol = 1e-5f * (node.radius + node.center.length()) + 1e-7f;
    // Sphere contains every disk below: test the center and 32 rim points.
    for (uint32_t k = range[i].begin; k < range[i].end; ++k) {
      const Surfel& s = t.surfels[k];
      const Imath::V3f tt = std::abs(s.normal.x) < 0.9f ? Imath::V3f(1, 0, 0) : Imath::V3f(0, 1, 0);
      const Imath::V3f e1 = s.normal.cross(tt).normalized(), e2 = s.normal.cross(e1);
      ASSERT_LE((s.position - node.center).length(), node.radius + tol);
      for (int j = 0; j < 32; ++j) {
        const float phi = 2 * float(M_PI) * j / 32;
        const Imath::V3f rim = s.position + s.radius * (std::cos(phi) * e1 + std::sin(phi) * e2);
        ASSERT_LE((rim - node.center).length(), node.radius + tol) << "node " << i << " surfel " << k;
      }
      // Normal cone contains the normal.
      ASSERT_GE(node.cone_axis.dot(s.normal), node.cone_cos - 1e-5f) << "node " << i << " surfel " << k;
    }
    // Area is the sum of surfel areas; payload is the definition.
    double area = 0;
    const Vec36 ref = reference_payload(&t.surfels[range[i].begin], range[i].end - range[i].begin, &area);
    ASSERT_NEAR(node.area, area, 1e-4 * area) << "node " << i;
    ASSERT_LT(relative_error(payload_of(node), ref), 1e-4) << "node " << i;

    if (node.is_leaf()) continue;
    const Node& c0 = t.nodes[node.children[0].index];
    const Node& c1 = t.nodes[node.children[1].index];
    // Sphere contains the children's spheres.
    for (const Node* c : {&c0, &c1}) {
      ASSERT_LE((c->center - node.center).length() + c->radius, node.radius + tol) << "node " << i;
    }
    // Payload is the area-weighted average of the children's.
    Vec36 avg{};
    const Vec36 p0 = payload_of(c0), p1 = payload_of(c1);
    for (int k = 0; k < 36; ++k) avg[k] = (c0.area * p0[k] + c1.area * p1[k]) / (double(c0.area) + c1.area);
    ASSERT_LT(relative_error(payload_of(node), avg), 1e-4) << "node " << i;
    ASSERT_NEAR(node.area, double(c0.area) + c1.area, 1e-5 * node.area);
  }

  // The root's area is the total area of the input (up to quantization).
  double total = 0;
  for (const auto& s : input) total += M_PI * double(s.radius) * s.radius;
  EXPECT_NEAR(t.nodes[0].area, total, 1e-3 * total);
}

INSTANTIATE_TEST_SUITE_P(LeafSizes, TreeInvariants, ::testing::Values(1u, 4u, 7u, 32u));

TEST(TreeBuilder, FarClustersSplitAtTheRoot) {
  // Two clusters far apart: radix splits separate them at the root, where
  // a split by count could mix them.
  std::vector<Surfel> in = test::random_surfels(1000, 8);
  for (size_t i = 0; i < in.size(); ++i) {
    in[i].position = Imath::V3f(0.01f * float(i % 10), 0.01f * float(i / 10 % 10), 0.01f * float(i / 100));
    if (i % 3 == 0) in[i].position += Imath::V3f(100, 100, 100);  // 334 far away
  }
  const BuiltTree t = build_tree(in, {});
  const Node& root = t.nodes[0];
  ASSERT_EQ(root.child_count, 2u);
  const Node& a = t.nodes[root.children[0].index];
  const Node& b = t.nodes[root.children[1].index];
  EXPECT_LT(a.radius, 1.f);
  EXPECT_LT(b.radius, 1.f);
  EXPECT_NEAR(a.center.x, 0.05f, 0.1f);
  EXPECT_NEAR(b.center.x, 100.05f, 0.1f);
}

TEST(TreeBuilder, DeterministicAcrossRunsAndThreads) {
  // Large enough to take the parallel path.
  const auto input = test::random_surfels(50000, 3);
  const BuiltTree a = build_tree(input, {});
  const BuiltTree b = build_tree(input, {});
  ASSERT_EQ(a.nodes.size(), b.nodes.size());
  for (size_t i = 0; i < a.nodes.size(); ++i) {
    ASSERT_EQ(a.nodes[i].center, b.nodes[i].center);
    ASSERT_EQ(a.nodes[i].radius, b.nodes[i].radius);
    ASSERT_EQ(payload_of(a.nodes[i]), payload_of(b.nodes[i]));
  }
  for (size_t i = 0; i < a.surfels.size(); ++i) ASSERT_TRUE(test::same_surfel(a.surfels[i], b.surfels[i]));
}

TEST(TreeBuilder, DegenerateInputs) {
  // One surfel: a single leaf.
  auto one = test::random_surfels(1);
  const BuiltTree t1 = build_tree(one, {});
  ASSERT_EQ(t1.nodes.size(), 1u);
  EXPECT_TRUE(t1.nodes[0].is_leaf());
  EXPECT_GE(t1.nodes[0].radius, one[0].radius);

  // All surfels at one point: equal codes split by index, a balanced tree
  // (100 = 25 leaves of 4) with proper spheres.
  auto same = test::random_surfels(100);
  for (auto& s : same) s.position = {1, 2, 3};
  const BuiltTree t2 = build_tree(same, {});
  EXPECT_LE(t2.max_depth, 6u);
  EXPECT_GE(t2.leaf_count, 25u);
  float max_r = 0;
  for (const auto& s : same) max_r = std::max(max_r, s.radius);
  EXPECT_GE(t2.nodes[0].radius, max_r);

  // Zero-area surfels: zero payload, no NaN.
  auto dots = test::random_surfels(10);
  for (auto& s : dots) s.radius = 0;
  const BuiltTree t3 = build_tree(dots, {});
  for (const Node& n : t3.nodes) {
    EXPECT_EQ(n.area, 0.f);
    for (float c : n.coverage_sh) EXPECT_EQ(c, 0.f);
  }

  // Unnormalized normals are renormalized.
  auto longn = test::random_surfels(5);
  for (auto& s : longn) s.normal *= 3.f;
  const BuiltTree t4 = build_tree(longn, {});
  for (const auto& s : t4.surfels) EXPECT_NEAR(s.normal.length(), 1.f, 1e-6f);
}

TEST(TreeBuilder, RejectsBadInput) {
  EXPECT_THROW(build_tree({}, {}), InvalidArgument);
  auto bad = test::random_surfels(20);
  bad[13].position.y = std::numeric_limits<float>::quiet_NaN();
  try {
    build_tree(bad, {});
    FAIL() << "NaN position accepted";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("surfel 13"), std::string::npos) << e.what();
  }
  auto neg = test::random_surfels(20);
  neg[4].radius = -1;
  EXPECT_THROW(build_tree(neg, {}), InvalidArgument);
  auto zero = test::random_surfels(20);
  zero[2].normal = {0, 0, 0};
  EXPECT_THROW(build_tree(zero, {}), InvalidArgument);
  auto dark = test::random_surfels(20);
  dark[7].radiance.y = -0.5f;  // V2 colours have no sign
  EXPECT_THROW(build_tree(dark, {}), InvalidArgument);
}

TEST(MemoryTree, ServesPageZero) {
  const BuiltTree t = build_tree(test::random_surfels(100), {});
  const size_t nodes = t.nodes.size();
  MemoryTree m(t);
  EXPECT_EQ(m.root(), (NodeRef{0, 0}));
  EXPECT_EQ(m.page(0)->nodes.size(), nodes);
  EXPECT_THROW(m.page(1), InvalidArgument);
}

}  // namespace
}  // namespace pbgi::tree
